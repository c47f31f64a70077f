from setuptools import find_packages, setup

package_name = "foos_policy"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="RL training, evaluation and policy_node (filled by the policy issue).",
    license="Apache-2.0",
    entry_points={"console_scripts": []},
)
