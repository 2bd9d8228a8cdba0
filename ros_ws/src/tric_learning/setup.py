from setuptools import find_packages, setup

PACKAGE = "tric_learning"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="TRIC maintainers",
    maintainer_email="maintainers@tric-ros.org",
    description="TRIC learning: task-space features and their Jacobians, MCAP datasets and the "
    "recorder node, the value function, its losses and training, the DPL baseline.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "recorder = tric_learning.nodes:recorder",
            "tric-record = tric_learning.commands:tric_record",
            "tric-analyze = tric_learning.commands:tric_analyze",
        ]
    },
)
