"""YAML with line numbers: every value keeps the line it came from, so errors can point at it.

PyYAML's ``safe_load`` forgets where values were; this walks the composed node tree instead, builds plain
Python data and a map from each YAML path (a tuple of keys and indices) to its 1-based line. It also
refuses duplicate keys, which ``safe_load`` silently resolves to the last one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

YamlPath = tuple[str | int, ...]


class ScenarioFileError(ValueError):
    """A scenario file that cannot be used; the message lists every problem with file, line and YAML path."""

    def __init__(self, file: Path | str, problems: list[str]) -> None:
        self.file = str(file)
        self.problems = problems
        super().__init__(f"{file}: {len(problems)} problem(s)\n" + "\n".join(f"  {p}" for p in problems))


@dataclass
class YamlDocument:
    """Parsed YAML data plus the line of every path in it."""

    file: Path
    data: Any
    lines: dict[YamlPath, int] = field(default_factory=dict)

    def line_of(self, path: YamlPath) -> int | None:
        """The line of ``path``, or of its closest ancestor that has one."""
        for end in range(len(path), -1, -1):
            if path[:end] in self.lines:
                return self.lines[path[:end]]
        return None

    def locate(self, path: YamlPath) -> str:
        """``file:line: a.b[0].c`` for messages."""
        line = self.line_of(path)
        return f"{self.file}:{line if line is not None else '?'}: {format_path(path) or '(top level)'}"


def format_path(path: YamlPath) -> str:
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def load_yaml(file: Path | str) -> YamlDocument:
    """Parse ``file``; a missing file or a YAML syntax error raises :class:`ScenarioFileError`."""
    file = Path(file)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as error:
        raise ScenarioFileError(file, [f"{file}: cannot read: {error.strerror or error}"]) from error
    except UnicodeDecodeError as error:
        raise ScenarioFileError(file, [f"{file}: not a text file (byte {error.start} is not UTF-8)"]) from error
    try:
        loader = yaml.SafeLoader(text)
    except yaml.reader.ReaderError as error:  # control characters: a binary file
        raise ScenarioFileError(file, [f"{file}: not a YAML text file: {error}"]) from error
    try:
        root = loader.get_single_node()
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"{file}:{mark.line + 1}" if mark is not None else str(file)
        raise ScenarioFileError(file, [f"{where}: invalid YAML: {getattr(error, 'problem', error)}"]) from error
    finally:
        loader.dispose()
    document = YamlDocument(file, None)
    problems: list[str] = []
    document.data = _build(root, (), document, problems, yaml.SafeLoader("")) if root is not None else {}
    if problems:
        raise ScenarioFileError(file, problems)
    return document


def _build(node: yaml.Node, path: YamlPath, document: YamlDocument, problems: list[str], constructor: yaml.SafeLoader) -> Any:
    document.lines[path] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        result: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = constructor.construct_object(key_node)
            if key in result:
                problems.append(
                    f"{document.file}:{key_node.start_mark.line + 1}: {format_path((*path, key))}: duplicate key"
                )
                continue
            result[key] = _build(value_node, (*path, key), document, problems, constructor)
            document.lines[(*path, key)] = key_node.start_mark.line + 1
        return result
    if isinstance(node, yaml.SequenceNode):
        return [_build(item, (*path, i), document, problems, constructor) for i, item in enumerate(node.value)]
    return constructor.construct_object(node)


def deep_merge(base: Any, override: Any) -> Any:
    """``override`` applied on ``base``: mappings merge key by key, anything else (lists too) is replaced."""
    if isinstance(base, dict) and isinstance(override, dict):
        merged = dict(base)
        for key, value in override.items():
            merged[key] = deep_merge(base.get(key), value) if key in base else value
        return merged
    return override
