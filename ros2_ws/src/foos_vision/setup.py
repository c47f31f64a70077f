from glob import glob

from setuptools import find_packages, setup

package_name = "foos_vision"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("foos_vision/config/*.yaml")),
    ],
    package_data={package_name: ["config/*.yaml"]},
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="foos developers",
    maintainer_email="dev@foos.local",
    description="Camera tracker for the foosball table: synthetic camera, ArUco homography, ball tracking.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "render_video = foos_vision.render_cli:main",
            "track_video = foos_vision.track_cli:main",
            "tracker_node = foos_vision.tracker_node:main",
            "video_source = foos_vision.video_source:main",
            "calibrate_camera = foos_vision.calibrate_camera:main",
            "bench_vision = foos_vision.bench:main",
        ]
    },
)
