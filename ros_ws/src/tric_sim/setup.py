from setuptools import find_packages, setup

PACKAGE = "tric_sim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        (
            "share/" + PACKAGE + "/urdf",
            [
                "tric_sim/description/tric_arm_hand.urdf",
                "tric_sim/description/tric_arm_hand.srdf",
                "tric_sim/description/tric_arm_hand.yaml",
                "tric_sim/description/panda.urdf",
                "tric_sim/description/panda.srdf",
                "tric_sim/description/panda.yaml",
            ],
        ),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="TRIC maintainers",
    maintainer_email="maintainers@tric-ros.org",
    description="The world of TRIC: the robot model (URDF, Pinocchio, coal), scenes and "
    "situations, the PyBullet simulator node, the teachers and the hidden task "
    "metrics.",
    license="Apache-2.0",
    package_data={PACKAGE: ["description/*.urdf", "description/*.srdf", "description/*.yaml"]},
    entry_points={
        "console_scripts": [
            "simulator = tric_sim.nodes:simulator",
            "teacher = tric_sim.nodes:teacher",
            "tric-robot-check = tric_sim.commands:tric_robot_check",
            "tric-snapshot = tric_sim.commands:tric_snapshot",
            "visualizer = tric_sim.nodes:visualizer",
        ]
    },
)
