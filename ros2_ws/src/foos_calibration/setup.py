from setuptools import find_packages, setup

package_name = "foos_calibration"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="Calibration of the table's simulation against measured data, and the measured-data generator.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "calibrate = foos_calibration.cli:main",
            "generate_measured = foos_calibration.generate:main",
        ],
    },
)
