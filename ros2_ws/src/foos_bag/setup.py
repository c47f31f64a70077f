from setuptools import find_packages, setup

package_name = "foos_bag"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    tests_require=["pytest"],
    zip_safe=True,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="rosbag2 record, play, info and numpy readers and writers of bags.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "ros2_bag = foos_bag.cli:main",
            "recorder = foos_bag.recorder:main",
            "player = foos_bag.player:main",
            "load_publisher = foos_bag.load_publisher:main",
        ]
    },
)
