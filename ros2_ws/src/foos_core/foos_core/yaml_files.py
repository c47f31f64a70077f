"""Reading the workspace's YAML files (parameter files, camera configs, markers) with one-line errors."""
from __future__ import annotations

from pathlib import Path

import yaml


def read_mapping(path: Path, what: str, error: type[Exception] = ValueError) -> dict:
    """The YAML mapping in `path` (an empty file is an empty mapping), or `error` with a one-line reason
    naming the file: not valid YAML, or not a mapping ("a {what} is a YAML mapping")."""
    try:
        tree = yaml.safe_load(Path(path).read_text()) or {}
    except yaml.YAMLError as problem:
        raise error(f"{path}: not valid YAML ({problem})".replace("\n", " ")) from None
    if not isinstance(tree, dict):
        raise error(f"{path}: a {what} is a YAML mapping")
    return tree
