"""A robot's URDF derived from another one, as its profile's `derive` entry says (docs/robots.md):
the source's links and joints kept, each link's visual meshes replaced by its collision primitives
(what PyBullet's software renderer and the viewer draw), and the fixed frames the profile's
landmarks need added as links on fixed joints (each with a negligible inertial: PyBullet would give
a link without one 1 kg). Writes the profile's `urdf`:

    python -m tric_sim.world.derived_urdf ROBOT     (a shipped profile's name or a profile file)

`derive` gives `source`, a URDF file (relative to the profile) or `DISTRIBUTION:PATH`, a file
installed with a Python distribution (e.g. `example-robot-data:cmeel.prefix/share/...`),
`frames`: name -> {parent: link, xyz: [m, m, m], rpy: [rad, rad, rad]}, and optionally
`collisions`: link -> a list of primitives that replace the link's collision geometry, each one of
{box: [x, y, z]}, {sphere: radius}, {cylinder: [radius, length]}, with xyz and rpy as a frame's.
"""

import copy
import hashlib
import importlib.metadata
import pathlib
import sys
import xml.etree.ElementTree as ET

import yaml

from tric_sim.tools.output_files import write_text_atomic
from tric_sim.world.robot_profile import DEFAULT_ROBOT, profile_path

#: The colour the derived visuals are drawn in (rgba).
MATERIAL, MATERIAL_RGBA = "derived_grey", "0.62 0.64 0.7 1"
#: An added frame's mass, kg, and its principal moments of inertia, kg m^2 (the paper robot's
#: landmark frames carry the same).
FRAME_MASS, FRAME_INERTIA = "0.001", "1e-8"


def source_file(source: str, profile: pathlib.Path) -> pathlib.Path:
    """The source URDF of a `derive` entry: DISTRIBUTION:PATH (a file installed with a Python
    distribution), or a path relative to the profile file; ValueError if it is not there."""
    distribution, separator, inside = source.partition(":")
    if separator and not pathlib.Path(source).is_absolute():
        try:
            installed = importlib.metadata.distribution(distribution)
            path = pathlib.Path(str(installed.locate_file(inside)))
        except importlib.metadata.PackageNotFoundError:
            raise ValueError(f"the distribution '{distribution}' is not installed") from None
    else:
        path = profile.parent / source
    if not path.is_file():
        raise ValueError(f"the source URDF {path} does not exist")
    return path


def _origin(parent: ET.Element, entry: dict) -> ET.Element:
    """An <origin> under parent from an entry's xyz and rpy (default zeros)."""
    xyz = " ".join(f"{float(v)!r}" for v in entry.get("xyz", (0.0, 0.0, 0.0)))
    rpy = " ".join(f"{float(v)!r}" for v in entry.get("rpy", (0.0, 0.0, 0.0)))
    return ET.SubElement(parent, "origin", xyz=xyz, rpy=rpy)


def _primitive(entry, where: str) -> ET.Element:
    """A <collision> element of one `collisions` primitive; ValueError naming where it is for a
    shape that is not a box, a sphere or a cylinder of positive sizes."""
    shapes = {"box": ("size", 3), "sphere": ("radius", 1), "cylinder": (("radius", "length"), 2)}
    kinds = [kind for kind in shapes if isinstance(entry, dict) and kind in entry]
    if len(kinds) != 1:
        raise ValueError(f"{where}: give one of box, sphere or cylinder")
    kind = kinds[0]
    names, count = shapes[kind]
    sizes = entry[kind] if isinstance(entry[kind], list) else [entry[kind]]
    if len(sizes) != count or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in sizes
    ):
        raise ValueError(f"{where}: {kind} takes {count} positive size(s), m")
    collision = ET.Element("collision")
    _origin(collision, entry)
    attributes = (
        {names: " ".join(f"{float(v)!r}" for v in sizes)}
        if isinstance(names, str)
        else {name: f"{float(v)!r}" for name, v in zip(names, sizes)}
    )
    ET.SubElement(ET.SubElement(collision, "geometry"), kind, attributes)
    return collision


def derived_urdf(source: pathlib.Path, frames: dict, collisions: dict | None = None) -> str:
    """The derived URDF's text (see the module docstring) of the source URDF, the frames to add
    and the links whose collision geometry to replace; ValueError for a frame on a link the source
    lacks, or one it has already, and for a replaced link it lacks or a malformed primitive."""
    root = ET.parse(source).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
    for name, primitives in (collisions or {}).items():
        if name not in links:
            raise ValueError(f"collisions: '{name}' is not a link of {source.name}")
        if not isinstance(primitives, list) or not primitives:
            raise ValueError(f"collisions: '{name}' takes a list of primitives")
        for collision in links[name].findall("collision"):
            links[name].remove(collision)
        for k, entry in enumerate(primitives):
            links[name].append(_primitive(entry, f"collisions: {name}[{k}]"))
    material = ET.Element("material", name=MATERIAL)
    ET.SubElement(material, "color", rgba=MATERIAL_RGBA)
    root.insert(0, material)
    for link in links.values():
        for visual in link.findall("visual"):
            link.remove(visual)
        for collision in link.findall("collision"):
            visual = copy.deepcopy(collision)
            visual.tag = "visual"
            ET.SubElement(visual, "material", name=MATERIAL)
            link.insert(0, visual)
    for name, frame in frames.items():
        if name in links:
            raise ValueError(f"frame '{name}' is a link of {source.name} already")
        if not isinstance(frame, dict) or frame.get("parent") not in links:
            raise ValueError(f"frame '{name}': its parent must be a link of {source.name}")
        inertial = ET.SubElement(ET.SubElement(root, "link", name=name), "inertial")
        ET.SubElement(inertial, "mass", value=FRAME_MASS)
        moments = {f"i{axes}": FRAME_INERTIA for axes in ("xx", "yy", "zz")}
        ET.SubElement(inertial, "inertia", {**moments, "ixy": "0", "ixz": "0", "iyz": "0"})
        joint = ET.SubElement(root, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(joint, "parent", link=frame["parent"])
        ET.SubElement(joint, "child", link=name)
        _origin(joint, frame)
    ET.indent(root)
    digest = hashlib.sha256(source.read_bytes()).hexdigest()
    header = (
        f"<!-- Derived by `python -m tric_sim.world.derived_urdf` from {source.name} "
        f"sha256={digest}: visuals replaced by the collision primitives, "
        f"{len(frames)} landmark frames added, the collision geometry of "
        f"{len(collisions or {})} links replaced. -->"
    )
    return f'<?xml version="1.0"?>\n{header}\n{ET.tostring(root, encoding="unicode")}\n'


def write_derived_urdf(robot: str = DEFAULT_ROBOT) -> pathlib.Path:
    """Write the URDF a profile derives (its `derive` entry) where its `urdf` entry says."""
    path = profile_path(robot)
    data = yaml.safe_load(path.read_text())
    derive = data.get("derive") if isinstance(data, dict) else None
    if not isinstance(derive, dict) or "source" not in derive:
        raise ValueError(f"robot profile {path} derives no URDF (no derive: source)")
    text = derived_urdf(
        source_file(derive["source"], path), derive.get("frames") or {}, derive.get("collisions")
    )
    return write_text_atomic(path.parent / data["urdf"], text)


if __name__ == "__main__":
    print(f"wrote {write_derived_urdf(sys.argv[1] if len(sys.argv) > 1 else DEFAULT_ROBOT)}")
