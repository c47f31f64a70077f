from glob import glob

from setuptools import find_packages, setup

package_name = "foos_policy"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        # trained policies (SB3 zips) and their training metrics, found by name by policy_node / evaluate
        ("share/" + package_name + "/policies", sorted(glob("policies/*.zip") + glob("policies/*.csv") + glob("policies/*.json"))),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="SAC/TQC training on the foosball twin, honest evaluation, and policy_node.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "train = foos_policy.train:main",
            "evaluate = foos_policy.evaluate:main",
            "evaluate_bag = foos_policy.evaluate_bag:main",
            "policy_node = foos_policy.policy_node:main",
        ],
    },
)
