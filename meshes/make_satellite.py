"""A small-satellite structural deck in Nastran bulk data, the way a structural team would hand it over (issue 33).

Plain numpy, no gmsh: ``python meshes/make_satellite.py`` writes ``meshes/satellite.bdf`` (``n = 24``); the
tests call :func:`deck` with a coarse ``n``.  SI units (m, W/(m K), kg/m³, J/(kg K)).

The structure (a 0.6 x 0.6 x 0.8 m box, element size h = 0.6 / n):

* panels, CQUAD4 on one conforming grid: the four side walls (PID 1, aluminium 1.5 mm), the top panel (PID 2,
  CFRP, PCOMP of 4 plies), the bottom panel (PID 3, aluminium 3 mm) with its four launcher-interface corner
  patches (PID 5, same section, held at the adapter temperature by the case), and an equipment deck at half
  height (PID 4, CFRP PCOMP) whose edges share the walls' nodes (T-junctions);
* stiffeners, CBAR on panel nodes only: the twelve box edges (PID 11), the deck-to-wall junction lines (PID 12)
  and a hat stiffener across the top panel (PID 11): every node of these bars belongs to a panel;
* struts, CBAR (PID 13, titanium tube): a tripod from three fittings on the bottom panel to a junction under the
  deck, and a post from the junction to the deck centre (four bars meet at the junction); a mast (PID 14) from a
  top-panel fitting up out of the box;
* fittings, CHEXA: the three tripod feet (PID 21, 2 x 2 x 1 hexes each) and four single-hex antenna mounts on the
  top panel (PID 21), each sitting on panel nodes (they touch the panels by nodes, not through a face of their
  own part); an electronics unit (PID 22, 4 x 4 x 2 hexes) 10 mm above the deck, tied to it by four RBE2; a
  battery (PID 23, 3 x 3 x 2 hexes) 10 mm above the deck, on four CBUSH (PBUSH 24).

Materials are MAT4 (conductivity, specific heat, density) with a matching MAT1 (elastic, for a thermo-elastic
run); PBAR areas are the sections' areas.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

LX, LY, LZ = 0.6, 0.6, 0.8


class _Deck:
    """GRIDs keyed by position (rounded to 1e-6 m) so that conforming meshes share nodes, and cards."""

    def __init__(self):
        self.grid: dict[tuple, int] = {}
        self.lines: list[str] = []
        self.eid = 0

    def node(self, x, y, z) -> int:
        key = (round(float(x), 6), round(float(y), 6), round(float(z), 6))
        gid = self.grid.get(key)
        if gid is None:
            gid = self.grid[key] = len(self.grid) + 1
        return gid

    def element(self, card: str, pid: int, *gids) -> int:
        self.eid += 1
        fields = [card, str(self.eid), str(pid), *map(str, gids)]
        self.lines.append(",".join(fields[:9]))
        if len(fields) > 9:  # small-field free format: 8 data fields per line, then a continuation line
            self.lines.append("," + ",".join(fields[9:]))
        return self.eid

    def quad_grid(self, origin, du, dv, nu: int, nv: int, pid, skip=None):
        """CQUAD4 on origin + i du/nu + j dv/nv; ``pid(i, j)`` or an int; normals du x dv."""
        o, du, dv = (np.asarray(a, float) for a in (origin, du, dv))
        for j in range(nv):
            for i in range(nu):
                c = [self.node(*(o + a * du / nu + b * dv / nv)) for a, b in ((i, j), (i + 1, j), (i + 1, j + 1),
                                                                               (i, j + 1))]
                self.element("CQUAD4", pid(i, j) if callable(pid) else pid, *c)

    def bars(self, points, pid: int):
        gids = [self.node(*p) for p in points]
        for a, b in zip(gids[:-1], gids[1:]):
            pa, pb = np.asarray(points[0]), np.asarray(points[-1])
            v = np.cross(pb - pa, [0.0, 0.0, 1.0])
            v = v if np.linalg.norm(v) > 1e-9 else np.array([1.0, 0.0, 0.0])  # orientation vector off the axis
            self.lines.append(",".join(["CBAR", str(self.eid + 1), str(pid), str(a), str(b),
                                        *(f"{x:.3f}" for x in v / np.linalg.norm(v))]))
            self.eid += 1
        return gids

    def hex_block(self, origin, size, counts, pid: int):
        """CHEXA block; returns the (nx+1, ny+1, nz+1) GRID ids."""
        o, s, n = np.asarray(origin, float), np.asarray(size, float), counts
        g = np.empty([c + 1 for c in n], np.int64)
        for idx in np.ndindex(*g.shape):
            g[idx] = self.node(*(o + s * np.asarray(idx) / np.asarray(n)))
        for i, j, k in np.ndindex(*n):
            c = [g[i, j, k], g[i + 1, j, k], g[i + 1, j + 1, k], g[i, j + 1, k],
                 g[i, j, k + 1], g[i + 1, j, k + 1], g[i + 1, j + 1, k + 1], g[i, j + 1, k + 1]]
            self.element("CHEXA", pid, *c)
        return g


def deck(n: int = 24) -> str:
    """The deck's text for element size h = 0.6 / n (n a multiple of 6, at least 6)."""
    if n < 6 or n % 6:
        raise ValueError("n must be a multiple of 6, at least 6")
    h = LX / n
    nz = round(LZ / h)
    d = _Deck()
    # panels: outward normals
    d.quad_grid((0, 0, 0), (0, LY, 0), (0, 0, LZ), n, nz, 1)          # -X wall (normal -x)
    d.quad_grid((LX, 0, 0), (0, 0, LZ), (0, LY, 0), nz, n, 1)         # +X wall
    d.quad_grid((0, 0, 0), (0, 0, LZ), (LX, 0, 0), nz, n, 1)          # -Y wall
    d.quad_grid((0, LY, 0), (LX, 0, 0), (0, 0, LZ), n, nz, 1)         # +Y wall
    d.quad_grid((0, 0, LZ), (LX, 0, 0), (0, LY, 0), n, n, 2)          # top (normal +z)
    corner = max(1, n // 12)                                          # launcher feet: corner patches

    def bottom_pid(i, j):
        near = lambda a: a < corner or a >= n - corner  # noqa: E731
        return 5 if near(i) and near(j) else 3

    d.quad_grid((0, 0, 0), (0, LY, 0), (LX, 0, 0), n, n, bottom_pid)  # bottom (normal -z)
    zd = LZ / 2
    d.quad_grid((0, 0, zd), (LX, 0, 0), (0, LY, 0), n, n, 4)          # equipment deck (normal +z)
    # stiffeners: box edges, deck junctions, a hat stiffener across the top panel
    edge = lambda p, q, m: [np.asarray(p) + (np.asarray(q) - np.asarray(p)) * t for t in np.linspace(0, 1, m + 1)]  # noqa: E731
    for x in (0, LX):
        for y in (0, LY):
            d.bars(edge((x, y, 0), (x, y, LZ), nz), 11)
    for z in (0, LZ):
        d.bars(edge((0, 0, z), (LX, 0, z), n), 11)
        d.bars(edge((0, LY, z), (LX, LY, z), n), 11)
        d.bars(edge((0, 0, z), (0, LY, z), n), 11)
        d.bars(edge((LX, 0, z), (LX, LY, z), n), 11)
    for p, q in (((0, 0, zd), (LX, 0, zd)), ((0, LY, zd), (LX, LY, zd)), ((0, 0, zd), (0, LY, zd)),
                 ((LX, 0, zd), (LX, LY, zd))):
        d.bars(edge(p, q, n), 12)
    d.bars(edge((0, LY / 2, LZ), (LX, LY / 2, LZ), n), 11)
    # tripod fittings on the bottom panel (2 x 2 x 1 hexes on panel nodes), feet at the fittings' top centres
    t_fit = 0.02
    feet = []
    for fx, fy in ((n // 6, n // 6), (n - n // 6 - 2, n // 6), (n // 2 - 1, n - n // 6 - 2)):
        d.hex_block((fx * h, fy * h, 0.0), (2 * h, 2 * h, t_fit), (2, 2, 1), 21)
        feet.append(np.array([(fx + 1) * h, (fy + 1) * h, t_fit]))
    junction = np.array([LX / 2, LY / 2, zd / 2])
    for foot in feet:
        d.bars(edge(foot, junction, 6), 13)
    d.bars(edge(junction, (LX / 2, LY / 2, zd), 4), 13)
    # single-hex antenna mounts on the top panel, the mast on the first one
    mounts = [(n // 4, n // 4), (n - n // 4 - 1, n // 4), (n // 4, n - n // 4 - 1), (n - n // 4 - 1, n - n // 4 - 1)]
    for i, (mx, my) in enumerate(mounts):
        d.hex_block((mx * h, my * h, LZ), (h, h, t_fit), (1, 1, 1), 21)
        if i == 0:
            d.bars(edge((mx * h, my * h, LZ + t_fit), (mx * h, my * h, LZ + 0.3), 10), 14)
    # electronics unit on RBE2, battery on CBUSH: 10 mm above the deck
    gap = 0.01
    ex, ey = n // 6, n // 2
    unit = d.hex_block((ex * h, ey * h, zd + gap), (3 * h, 3 * h, 0.12), (4, 4, 2), 22)
    bx, by = n - n // 6 - 2, n // 6
    batt = d.hex_block((bx * h, by * h, zd + gap), (2 * h, 2 * h, 0.08), (3, 3, 2), 23)
    rbe = []
    for i, j in ((0, 0), (1, 0), (0, 1), (1, 1)):  # the blocks' bottom corners to the deck nodes below them
        d.eid += 1
        rbe.append(f"RBE2,{d.eid},{d.node((ex + 3 * i) * h, (ey + 3 * j) * h, zd)},123456,{unit[-i, -j, 0]}")
    for i, j in ((0, 0), (1, 0), (0, 1), (1, 1)):
        d.eid += 1
        rbe.append(f"CBUSH,{d.eid},24,{batt[-i, -j, 0]},{d.node((bx + 2 * i) * h, (by + 2 * j) * h, zd)},,,,0")
    grids = [f"GRID,{gid},,{x:.6f},{y:.6f},{z:.6f}" for (x, y, z), gid in d.grid.items()]
    props = [
        "$ aluminium 7075: MAT4 K, CP, RHO; MAT1 E, G, NU, RHO, A (thermal expansion)",
        "MAT4,1,130.0,960.0,2810.0", "MAT1,1,71.7e9,,0.33,2810.0,23.4e-6",
        "$ CFRP face sheets (in-plane), titanium",
        "MAT4,2,30.0,900.0,1600.0", "MAT1,2,70.0e9,,0.30,1600.0,1.0e-6",
        "MAT4,3,7.0,560.0,4430.0", "MAT1,3,114.0e9,,0.34,4430.0,8.6e-6",
        "PSHELL,1,1,0.0015,1", "PSHELL,3,1,0.003,1", "PSHELL,5,1,0.003,1",
        "PCOMP,2,,,,,,,,+P2", "+P2,2,0.00025,0.0,,2,0.00025,90.0,,+P2B", "+P2B,2,0.00025,90.0,,2,0.00025,0.0",
        "PCOMP,4,,,,,,,,+P4", "+P4,2,0.0004,0.0,,2,0.0004,90.0,,+P4B", "+P4B,2,0.0004,90.0,,2,0.0004,0.0",
        "PBAR,11,1,1.6e-4", "PBAR,12,1,1.2e-4", "PBAR,13,3,2.4e-4", "PBAR,14,1,3.0e-4",
        "PSOLID,21,1", "PSOLID,22,1", "PSOLID,23,1",
        "PBUSH,24,K,1.0e6,1.0e6,1.0e6",
    ]
    head = ["$ fem2tmm satellite structure (meshes/make_satellite.py), n = %d, SI units" % n, "BEGIN BULK"]
    return "\n".join([*head, *grids, *d.lines, *rbe, *props, "ENDDATA"]) + "\n"


def main(argv=None) -> None:
    n = int((argv or sys.argv[1:] or [24])[0])
    out = Path(__file__).with_name("satellite.bdf")
    out.write_text(deck(n))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
