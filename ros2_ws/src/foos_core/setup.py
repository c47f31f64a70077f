from glob import glob

from setuptools import find_packages, setup

package_name = "foos_core"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={package_name: ["params/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/params", glob("foos_core/params/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="The table contract in code: names, the parameter file and geometry, joint order, stamps, node start-up.",
    license="Apache-2.0",
)
