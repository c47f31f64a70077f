from setuptools import find_packages, setup

package_name = "foos_sim"

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
    description="MuJoCo model of a regulation foosball table, the ROS-free simulation API, and sim_node.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "sim_node = foos_sim.sim_node:main",
            "record_sim = foos_sim.record_sim:main",
            # moved to foos_calibration; these say so and run it there
            "calibrate = foos_sim.moved:calibrate",
            "generate_measured = foos_sim.moved:generate_measured",
        ],
    },
)
