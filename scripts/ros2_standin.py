#!/usr/bin/env python3
"""A small stand-in for ros2cli on machines where only the ROS 2 Python wheels are installed.

It implements what this workspace needs, the way ros2cli does it:
  ros2 run PKG EXE [ARGS...]     exec <prefix>/lib/PKG/EXE found through the ament index
  ros2 pkg list | executables [PKG] | prefix PKG
  ros2 bag record|play|info ...  delegated to the foos_bag package's `ros2_bag` executable

scripts/env.sh puts it on PATH only when no real `ros2` is there, so a sourced ROS 2 install wins.
"""
import os
import sys


def die(message: str, code: int = 1) -> None:
    print(f"ros2: {message}", file=sys.stderr)
    sys.exit(code)


def prefixes() -> list[str]:
    return [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]


def packages() -> dict[str, str]:
    """Package name -> install prefix, first prefix wins (as in ament_index_python)."""
    found: dict[str, str] = {}
    for prefix in prefixes():
        index = os.path.join(prefix, "share", "ament_index", "resource_index", "packages")
        if os.path.isdir(index):
            for name in os.listdir(index):
                found.setdefault(name, prefix)
    return found


def executables(package: str, prefix: str) -> list[str]:
    lib = os.path.join(prefix, "lib", package)
    if not os.path.isdir(lib):
        return []
    return sorted(
        f for f in os.listdir(lib) if os.path.isfile(os.path.join(lib, f)) and os.access(os.path.join(lib, f), os.X_OK)
    )


def prefix_of(package: str) -> str:
    prefix = packages().get(package)
    if prefix is None:
        die(f"Package '{package}' not found (AMENT_PREFIX_PATH: is scripts/env.sh sourced?)")
    return prefix


def cmd_run(args: list[str]) -> None:
    if len(args) < 2 or args[0] in ("-h", "--help"):
        print("usage: ros2 run PACKAGE EXECUTABLE [ARGS ...] [--ros-args ...]")
        sys.exit(0 if args[:1] in (["-h"], ["--help"]) else 2)
    package, executable, rest = args[0], args[1], args[2:]
    prefix = prefix_of(package)
    path = os.path.join(prefix, "lib", package, executable)
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        available = ", ".join(executables(package, prefix)) or "none"
        die(f"No executable '{executable}' in package '{package}' (available: {available})")
    os.execv(path, [path, *rest])


def cmd_pkg(args: list[str]) -> None:
    verb = args[0] if args else "list"
    if verb == "list":
        print("\n".join(sorted(packages())))
    elif verb == "prefix" and len(args) == 2:
        print(prefix_of(args[1]))
    elif verb == "executables":
        names = [args[1]] if len(args) > 1 else sorted(packages())
        for name in names:
            for exe in executables(name, prefix_of(name)):
                print(f"{name} {exe}")
    else:
        die("usage: ros2 pkg list | prefix PACKAGE | executables [PACKAGE]", 2)


def cmd_bag(args: list[str]) -> None:
    tool = os.path.join(prefix_of("foos_bag"), "lib", "foos_bag", "ros2_bag")
    if not os.access(tool, os.X_OK):
        die("ros2 bag needs the foos_bag package's ros2_bag executable; rebuild with scripts/setup")
    os.execv(tool, [tool, *args])


COMMANDS = {"run": cmd_run, "pkg": cmd_pkg, "bag": cmd_bag}


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        sys.exit(0 if len(sys.argv) > 1 else 2)
    command = COMMANDS.get(sys.argv[1])
    if command is None:
        die(f"'{sys.argv[1]}' is not part of this stand-in (it offers: {', '.join(COMMANDS)}); "
            "install ROS 2 Jazzy for the full ros2cli", 2)
    command(sys.argv[2:])


if __name__ == "__main__":
    main()
