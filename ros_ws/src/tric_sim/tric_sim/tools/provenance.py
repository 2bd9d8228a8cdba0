"""What code made a result: a digest of a module's source and of every module of the project's
packages that it imports, directly or through others. A cached result (a trained model, a judged
episode) keyed on it is never re-used after a change of that code, module constants included.
ROS-free."""

import ast
import functools
import hashlib
import importlib.util
import pathlib

#: The project's Python packages: imports of these are followed, all others are left out.
PACKAGES = ("tric_sim", "tric_learning", "tric_control")
#: The digest's length in hex digits.
DIGEST_LENGTH = 16


def imported_modules(source: bytes, package: str) -> list:
    """The names a module's source imports (absolute and relative imports, and for `from X import
    Y` both X and X.Y, which may be a module), relative ones resolved within package."""
    names = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{parent}.{base}" if base else parent
            names += [base] + [f"{base}.{alias.name}" for alias in node.names]
    return names


def module_file(name: str):
    """The file of the project's module name (a package's __init__.py for a package), or None if
    name is not a module of PACKAGES (e.g. a function imported by name)."""
    if name.split(".")[0] not in PACKAGES:
        return None
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, AttributeError, ValueError):  # a parent that is a module, not a package
        return None
    if spec is None or not spec.origin or not pathlib.Path(spec.origin).is_file():
        return None
    return pathlib.Path(spec.origin), spec.submodule_search_locations is not None


@functools.cache
def code_digest(*modules: str) -> str:
    """A digest of the files of the given modules of PACKAGES and of every module of PACKAGES they
    import, transitively (sources, and compiled extensions as built); ValueError for a module that
    is not one of the project's."""
    files, todo = {}, list(modules)
    for name in modules:
        if module_file(name) is None:
            raise ValueError(f"{name} is not a module of {', '.join(PACKAGES)}")
    while todo:
        name = todo.pop()
        found = module_file(name)
        if found is None or name in files:
            continue
        path, is_package = found
        content = path.read_bytes()
        files[name] = content
        if path.suffix == ".py":
            package = name if is_package else name.rpartition(".")[0]
            todo += imported_modules(content, package)
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + hashlib.sha256(files[name]).digest())
    return digest.hexdigest()[:DIGEST_LENGTH]
