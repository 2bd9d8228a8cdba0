"""Input from files a user hands over, treated as hostile: YAML and JSON read and parsed with limits
on size, nesting depth and aliases, and a key repeated within one mapping refused rather than
silently taking the last value (read_data_file, load_data); input quoted in error messages at most
QUOTE_LIMIT characters at a time (quoted)."""

import json
import pathlib

import yaml

#: The largest file load_data reads, bytes (a situations file of 1000 situations is about 0.5 MB).
MAX_BYTES = 16 * 2**20
#: The deepest nesting of lists and mappings accepted (a situations file nests 4 deep).
MAX_DEPTH = 32
#: The most characters of the input an error message quotes.
QUOTE_LIMIT = 200


def quoted(value, limit: int = QUOTE_LIMIT) -> str:
    """str(value) for a string, else repr(value), cut to at most limit characters (the cut marked
    with "..." and the length it had). The data load_data returns is a tree (aliases refused), so
    its repr grows only as the file does."""
    text = value if isinstance(value, str) else repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} chars)"


class _LimitedLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses aliases and nesting deeper than MAX_DEPTH, as the parser
    meets them (before anything is built)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(
                None,
                None,
                f"an alias (*{quoted(event.anchor, 40)}): aliases are not accepted",
                event.start_mark,
            )
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"nesting deeper than {MAX_DEPTH} levels",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                repeated = key in seen
                seen.add(key)
            except TypeError:  # an unhashable key: PyYAML's own error follows
                continue
            if repeated:
                raise yaml.constructor.ConstructorError(
                    None, None, f"the key {quoted(key, 40)!r} repeated", key_node.start_mark
                )
        return super().construct_mapping(node, deep)


class RepeatedKey(ValueError):
    """A JSON object with a key repeated."""


def _unique_keys(pairs) -> dict:
    """A JSON object's dict, RepeatedKey if a key repeats (json.loads' object_pairs_hook)."""
    data = {}
    for key, value in pairs:
        if key in data:
            raise RepeatedKey(f"the key {quoted(key, 40)!r} repeated")
        data[key] = value
    return data


def check_input_file(path, what: str) -> pathlib.Path:
    """path as a Path if it names a regular file, else ValueError naming what: it does not exist,
    is a folder, or is another kind of file (a device such as /dev/zero, a pipe or a socket, read
    without end or not at all)."""
    path = pathlib.Path(path)
    where = f"{what} {quoted(str(path), 100)}"
    if path.is_file():
        return path
    if path.is_dir():
        raise ValueError(f"{where} is a folder, not a file")
    if path.exists():
        raise ValueError(f"{where} is not a regular file (a device, a pipe or a socket)")
    raise ValueError(f"{where} does not exist")


def read_data_file(path, what: str, json_format: bool | None = None):
    """The data of a YAML file (JSON for a .json suffix, or as json_format says), read by
    load_data's rules, or ValueError naming what and path: unreadable, larger than MAX_BYTES (read
    no further), not UTF-8, or refused by load_data."""
    path = pathlib.Path(path)
    source = f"{what} {path}"
    try:
        with path.open("rb") as file:
            raw = file.read(MAX_BYTES + 1)
    except OSError as error:
        raise ValueError(f"cannot read {source}: {error.strerror}") from None
    if len(raw) > MAX_BYTES:
        raise ValueError(f"{source} is larger than {MAX_BYTES // 2**20} MiB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{source} is not UTF-8 text (byte {error.start})") from None
    if json_format is None:
        json_format = path.suffix == ".json"
    return load_data(text, source, json_format=json_format)


def load_data(text: str, source: str, json_format: bool = False):
    """The data of a YAML (or, json_format, JSON) text, or ValueError in one line that names
    source: larger than MAX_BYTES, nested deeper than MAX_DEPTH, a YAML alias, or not parsing."""
    kind = "JSON" if json_format else "YAML"
    if len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise ValueError(f"{source} is larger than {MAX_BYTES // 2**20} MiB")
    try:
        data = (
            json.loads(text, object_pairs_hook=_unique_keys)
            if json_format
            else yaml.load(text, Loader=_LimitedLoader)
        )
    except (json.JSONDecodeError, RepeatedKey) as error:
        raise ValueError(f"{source} is not valid JSON: {quoted(str(error))}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)  # YAML's own message spans lines: say it in one
        detail = (
            f"{error.problem} at line {mark.line + 1}, column {mark.column + 1}"
            if mark is not None
            else str(error)
        )
        raise ValueError(f"{source} is not valid YAML: {quoted(detail)}") from None
    except RecursionError:  # the JSON parser recurses per level
        depth = MAX_DEPTH + 1
    else:
        depth = _depth(data)
    if depth > MAX_DEPTH:
        raise ValueError(f"{source} is not valid {kind}: nesting deeper than {MAX_DEPTH} levels")
    return data


def _depth(data) -> int:
    """How deep lists and mappings nest in data (0 for a scalar), without recursion."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, (list, dict)):
            deepest = max(deepest, level)
            if level <= MAX_DEPTH:
                stack += [
                    (v, level + 1) for v in (item.values() if isinstance(item, dict) else item)
                ]
    return deepest
