from pybind11.setup_helpers import Pybind11Extension, build_ext
from setuptools import find_packages, setup

PACKAGE = "tric_control"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    # TRIC's objective compiled (tric_control.objectives.value.ValueObjective uses it where it is
    # built)
    ext_modules=[
        Pybind11Extension(
            "tric_control._value_kernel", ["tric_control/value_kernel.cpp"], cxx_std=17
        )
    ],
    cmdclass={"build_ext": build_ext},
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="TRIC maintainers",
    maintainer_email="maintainers@tric-ros.org",
    description="TRIC control: the motion-rate QP controller and its node, the DPL controller, "
    "evaluation episodes, experiment runners, tables and plots.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "controller = tric_control.nodes:controller",
            "trainer = tric_control.nodes:trainer",
            "tric-train = tric_control.commands:tric_train",
            "tric-eval = tric_control.commands:tric_eval",
            "tric-demo = tric_control.commands:tric_demo",
            "tric-experiments = tric_control.commands:tric_experiments",
            "tric-study = tric_control.commands:tric_study",
        ]
    },
)
