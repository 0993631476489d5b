#!/usr/bin/env python3
"""Rebuilds the README's "Environment-map toolkit" section from docs/toolkit/*.md (each file's
headings one level down), between the `<!-- toolkit docs: begin/end -->` markers."""
import pathlib
import re

root = pathlib.Path(__file__).resolve().parents[1]
readme = (root / "README.md").read_text()
begin, end = "<!-- toolkit docs: begin -->\n", "<!-- toolkit docs: end -->"
head, rest = readme.split(begin, 1)
_, tail = rest.split(end, 1)
order = ["light_analysis", "map_layouts", "camera", "cube_layouts", "spherical_gaussians", "dataset"]
parts = [
    "## Environment-map toolkit\n\nOperators a lighting-research dataset pipeline is built from (lat-long conventions as in\n"
    "[Conventions](#conventions); `Rotate` is described under [Rotations](#rotations)).\n"
]
for name in order:
    text = (root / "docs" / "toolkit" / f"{name}.md").read_text()
    text = re.sub(r"^(#+) ", lambda m: "#" + m.group(1) + " ", text, flags=re.M)
    parts.append(text.strip() + "\n")
(root / "README.md").write_text(head + begin + "\n".join(parts) + "\n" + end + tail)
