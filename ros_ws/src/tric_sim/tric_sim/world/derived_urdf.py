"""A robot's URDF derived from another one, as its profile's `derive` entry says (docs/robots.md):
the source's links and joints kept, each link's visual meshes replaced by its collision primitives
(what PyBullet's software renderer and the viewer draw), and the fixed frames the profile's
landmarks need added as links on fixed joints. Writes the profile's `urdf`:

    python -m tric_sim.world.derived_urdf ROBOT     (a shipped profile's name or a profile file)

`derive` gives `source`, a URDF file (relative to the profile) or `DISTRIBUTION:PATH`, a file
installed with a Python distribution (e.g. `example-robot-data:cmeel.prefix/share/...`), and
`frames`: name -> {parent: link, xyz: [m, m, m], rpy: [rad, rad, rad]}.
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


def derived_urdf(source: pathlib.Path, frames: dict) -> str:
    """The derived URDF's text (see the module docstring) of the source URDF and the frames to
    add; ValueError for a frame on a link the source lacks, or one it has already."""
    root = ET.parse(source).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
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
        xyz = " ".join(f"{float(v)!r}" for v in frame.get("xyz", (0.0, 0.0, 0.0)))
        rpy = " ".join(f"{float(v)!r}" for v in frame.get("rpy", (0.0, 0.0, 0.0)))
        ET.SubElement(root, "link", name=name)
        joint = ET.SubElement(root, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(joint, "parent", link=frame["parent"])
        ET.SubElement(joint, "child", link=name)
        ET.SubElement(joint, "origin", xyz=xyz, rpy=rpy)
    ET.indent(root)
    digest = hashlib.sha256(source.read_bytes()).hexdigest()
    header = (
        f"<!-- Derived by `python -m tric_sim.world.derived_urdf` from {source.name} "
        f"sha256={digest}: visuals replaced by the collision primitives, "
        f"{len(frames)} landmark frames added. -->"
    )
    return f'<?xml version="1.0"?>\n{header}\n{ET.tostring(root, encoding="unicode")}\n'


def write_derived_urdf(robot: str = DEFAULT_ROBOT) -> pathlib.Path:
    """Write the URDF a profile derives (its `derive` entry) where its `urdf` entry says."""
    path = profile_path(robot)
    data = yaml.safe_load(path.read_text())
    derive = data.get("derive") if isinstance(data, dict) else None
    if not isinstance(derive, dict) or "source" not in derive:
        raise ValueError(f"robot profile {path} derives no URDF (no derive: source)")
    text = derived_urdf(source_file(derive["source"], path), derive.get("frames") or {})
    return write_text_atomic(path.parent / data["urdf"], text)


if __name__ == "__main__":
    print(f"wrote {write_derived_urdf(sys.argv[1] if len(sys.argv) > 1 else DEFAULT_ROBOT)}")
