"""The YAML front matter of a Hugging Face dataset card, written and read back without a YAML library.

The Hub reads a card's metadata from a YAML block between two ``---`` lines at the top of ``README.md``.
mgdata's cards (:mod:`mgdata.record.card`) need a small subset of YAML: ``key: scalar``, and ``key:``
followed by ``- item`` lines whose items are scalars or one-level mappings (continued on indented ``k: v``
lines); :func:`read_front_matter` also takes flow lists (``key: [a, b]``) and quoted scalars, as a hand
edit might write them. A scalar is written plain when YAML reads it back as the same string, else
double-quoted (a JSON string is a YAML one).

Example::

    text = dump_front_matter({"license": "apache-2.0", "tags": ["LeRobot", "mgdata"]})
    read_front_matter(text + "\n# body\n")   # {'license': 'apache-2.0', 'tags': ['LeRobot', 'mgdata']}
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from typing import Any

from mgdata.errors import DatasetError

REQUIRED_KEYS = ("license", "task_categories", "tags", "configs")
"""What the Hub and LeRobot's own cards put in every dataset card's front matter."""

Value = str | Sequence[str] | Sequence[Mapping[str, str]]
_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-/*]*")
_WORDS = {"true", "false", "yes", "no", "on", "off", "null", "y", "n"}  # plain scalars YAML reads otherwise
_KEY = r"[A-Za-z_][\w-]*"


def _scalar(value: str) -> str:
    return value if _PLAIN.fullmatch(value) and value.lower() not in _WORDS else json.dumps(value)


def dump_front_matter(data: Mapping[str, Value]) -> str:
    """``data`` as a front-matter block, ``---`` lines included (no trailing newline)."""
    lines = ["---"]
    for key, value in data.items():
        if isinstance(value, str):
            lines.append(f"{key}: {_scalar(value)}")
            continue
        lines.append(f"{key}:")
        for item in value:
            if isinstance(item, str):
                lines.append(f"- {_scalar(item)}")
            else:
                pairs = [f"{k}: {_scalar(v)}" for k, v in item.items()]
                lines += [f"- {pairs[0]}", *(f"  {p}" for p in pairs[1:])]
    return "\n".join([*lines, "---"])


def read_front_matter(text: str) -> dict[str, Any]:
    """The front matter at the top of ``text`` (the subset the module docstring names) as plain data.

    Raises:
        DatasetError: no front matter, or a line outside that subset (the message names the line).
    """
    lines = text.split("\n")
    if lines[0].rstrip() != "---":
        raise DatasetError("no YAML front matter (the first line is not '---')")
    end = next((i for i in range(1, len(lines)) if lines[i].rstrip() == "---"), None)
    if end is None:
        raise DatasetError("the YAML front matter is not closed by a '---' line")
    out: dict[str, Any] = {}
    key: str | None = None
    for n, raw in enumerate(lines[1:end], start=2):
        line = raw.rstrip()
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if not line.startswith((" ", "-")):
            name, colon, rest = line.partition(":")
            if not colon or not re.fullmatch(_KEY, name):
                raise DatasetError(f"front matter line {n} is not 'key: value': {line!r}")
            key, rest = name, rest.strip()
            out[key] = _flow(rest, n) if rest else []
            continue
        items = out.get(key) if key is not None else None
        if not isinstance(items, list):
            raise DatasetError(f"front matter line {n} continues no list: {line!r}")
        if line.startswith("- "):
            item = line[2:].strip()
            items.append(_pair(item, n, {}) if _is_pair(item) else _unquote(item, n))
        elif line.startswith("  ") and items and isinstance(items[-1], dict):
            _pair(line.strip(), n, items[-1])
        else:
            raise DatasetError(f"front matter line {n} is not a list item: {line!r}")
    return out


def _is_pair(item: str) -> bool:
    return bool(re.match(_KEY + r":(\s|$)", item))


def _pair(item: str, n: int, into: dict[str, Any]) -> dict[str, Any]:
    if not _is_pair(item):
        raise DatasetError(f"front matter line {n} is not 'key: value': {item!r}")
    name, _, rest = item.partition(":")
    into[name] = _flow(rest.strip(), n)
    return into


def _flow(value: str, n: int) -> Any:
    if value.startswith("[") and value.endswith("]"):
        return [_unquote(v.strip(), n) for v in value[1:-1].split(",") if v.strip()]
    return _unquote(value, n)


def _unquote(value: str, n: int) -> str:
    if value.startswith('"'):
        try:
            return str(json.loads(value))
        except ValueError:
            raise DatasetError(f"front matter line {n}: bad double-quoted string {value!r}") from None
    if value.startswith("'"):
        if len(value) < 2 or not value.endswith("'"):
            raise DatasetError(f"front matter line {n}: bad single-quoted string {value!r}")
        return value[1:-1].replace("''", "'")
    return value.split(" #", 1)[0].strip()


def card_problem(text: str) -> str | None:
    """What is wrong with the front matter of ``text`` as a Hub dataset card (``None``: nothing): it parses,
    and it has :data:`REQUIRED_KEYS` with the values LeRobot's cards have."""
    try:
        meta = read_front_matter(text)
    except DatasetError as err:
        return str(err)
    missing = [k for k in REQUIRED_KEYS if not meta.get(k)]
    if missing:
        return f"the front matter lacks {', '.join(missing)}"
    if "robotics" not in meta["task_categories"] or "LeRobot" not in meta["tags"]:
        return "the front matter's task_categories lack 'robotics' or its tags 'LeRobot'"
    configs = meta["configs"]
    if not all(isinstance(c, dict) and c.get("config_name") and c.get("data_files") for c in configs):
        return "the front matter's configs need a config_name and data_files each"
    return None
