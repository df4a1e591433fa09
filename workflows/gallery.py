"""Render every beam section and the default crankshaft as surface meshes into one PNG.

    python workflows/gallery.py [--out docs/gallery.png]

Each body is built and surface-meshed by the ``geometry`` package exactly as ``gcms mesh``
would (same builders, same default mesh size, order 1 for drawing), then drawn with
matplotlib's ``Poly3DCollection`` at equal scale on all axes, Lambert-shaded, with the
named surface groups coloured: end faces, main journals and crank pins.
"""
from __future__ import annotations

from pathlib import Path

import gmsh
import numpy as np
from common import REPO, parser, pyplot, save_figure

plt = pyplot()
from matplotlib.patches import Patch  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh  # noqa: E402
from common.sections import SECTIONS as EXAMPLE_SECTIONS  # noqa: E402
from geometry import SECTIONS  # noqa: E402
from geometry.meshing import add_body, gmsh_session, set_mesh_sizes  # noqa: E402

#: Each section (``common.sections``) is drawn as a beam this long (m).
BEAM_LENGTH = 0.1
CRANK_DRAW_SIZE = 0.005
BODY_COLOUR = (0.72, 0.74, 0.77)
GROUP_COLOURS = {"end_": (0.35, 0.70, 0.40), "journal_": (0.25, 0.50, 0.85),
                 "pin_": (0.93, 0.55, 0.20)}
LIGHT = np.array([-0.5, -0.6, 0.8]) / np.linalg.norm([-0.5, -0.6, 0.8])


def surface_triangles(raw_geometry: dict, raw_mesh: dict | None = None
                      ) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
    """The boundary triangles (n, 3, 3) of the body and the base colour of each."""
    geom = parse_geometry(raw_geometry)
    mesh = parse_mesh(raw_mesh, geom)
    with gmsh_session() as set_option:
        body = add_body(geom)
        set_mesh_sizes(set_option, body, mesh)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        xyz = np.empty((int(tags.max()) + 1, 3))
        xyz[tags] = coords.reshape(-1, 3)
        colour_of = {face: colour for name, faces in body.surfaces.items()
                     for prefix, colour in GROUP_COLOURS.items() if name.startswith(prefix)
                     for face in faces}
        triangles, colours = [], []
        for _, face in gmsh.model.getBoundary([(3, body.volume)], oriented=False):
            _, nodes = gmsh.model.mesh.getElementsByType(2, face)  # 3-node triangles
            triangles.append(xyz[nodes.reshape(-1, 3)])
            colours += [colour_of.get(face, BODY_COLOUR)] * (len(nodes) // 3)
    return np.concatenate(triangles), colours


def draw(ax, triangles: np.ndarray, colours: list, title: str, view: tuple[float, float],
         zoom: float = 1.0) -> None:
    """Lambert-shaded triangles at equal scale on all three axes."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    shade = 0.45 + 0.55 * np.abs(normals @ LIGHT)
    faces = np.clip(np.asarray(colours) * shade[:, None], 0.0, 1.0)
    ax.add_collection3d(Poly3DCollection(triangles, facecolors=faces, edgecolors=(0, 0, 0, 0.25),
                                         linewidths=0.15))
    lo, hi = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    ax.set_box_aspect(hi - lo, zoom=zoom)
    ax.view_init(*view)
    ax.set_axis_off()
    ax.set_title(title, fontsize=11)


def main(argv: list[str] | None = None) -> Path:
    out = parser(__doc__, out=REPO / "docs" / "gallery.png").parse_args(argv).out

    fig = plt.figure(figsize=(18, 13))
    grid = fig.add_gridspec(3, 5, height_ratios=(1, 1, 1.8))
    for k, section in enumerate(SECTIONS):
        raw = {"kind": "beam", "section": section, "length": BEAM_LENGTH,
               **EXAMPLE_SECTIONS[section]}
        triangles, colours = surface_triangles(raw)
        ax = fig.add_subplot(grid[divmod(k, 5)], projection="3d")
        draw(ax, triangles, colours, f"section = \"{section}\"", view=(22, -135))
    # finer than the default mesh: matplotlib sorts whole triangles by depth, and small
    # ones keep the pins from showing through the webs
    triangles, colours = surface_triangles({"kind": "crankshaft"}, {"size": CRANK_DRAW_SIZE})
    draw(fig.add_subplot(grid[2, :3], projection="3d"), triangles, colours,
         "crankshaft (defaults: inline-4, 0/180/180/0)", view=(18, -65), zoom=1.1)
    draw(fig.add_subplot(grid[2, 3:], projection="3d"), triangles, colours,
         "crankshaft seen along -z: pins at y = ±stroke/2", view=(90, -90), zoom=1.1)
    fig.legend(handles=[Patch(color=c, label=f"{p}*") for p, c in GROUP_COLOURS.items()],
               loc="lower center", ncol=3, frameon=False, fontsize=11)
    fig.suptitle("geometry: beam sections (0.1 m long, x = 0 end in front) and crankshaft",
                 fontsize=14)
    fig.subplots_adjust(left=0.01, right=0.99, top=0.94, bottom=0.04, wspace=0.02, hspace=0.08)
    save_figure(fig, out, tight=False)
    return out


if __name__ == "__main__":
    print(main())
