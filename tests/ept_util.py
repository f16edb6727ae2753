"""Write a small Entwine Point Tile index (EPT 1.0, LAZ nodes), as QGIS builds for a loaded
point cloud, from a LAS/LAZ file: a root node with every 8th point and four child nodes with
the rest by quadrant. Every point is in exactly one node."""
import json
from pathlib import Path

import numpy as np


def write_ept(las_path, folder, *, with_crs_in_nodes=False) -> Path:
    import laspy

    las = laspy.read(str(las_path))
    crs = las.header.parse_crs()
    folder = Path(folder)
    (folder / "ept-data").mkdir(parents=True)
    (folder / "ept-hierarchy").mkdir()
    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    lo = np.array([x.min(), y.min(), z.min()])
    hi = np.array([x.max(), y.max(), z.max()])
    half = float((hi - lo).max()) / 2 + 1
    mid = (lo + hi) / 2
    cube = [*(mid - half), *(mid + half)]
    idx = np.arange(x.size)
    root = idx % 8 == 0
    nodes = {"0-0-0-0": idx[root]}
    qx, qy = (x >= mid[0]).astype(int), (y >= mid[1]).astype(int)
    for i in (0, 1):
        for j in (0, 1):
            nodes[f"1-{i}-{j}-0"] = idx[~root & (qx == i) & (qy == j)]
    hierarchy = {}
    for key, sel in nodes.items():
        header = laspy.LasHeader(point_format=las.header.point_format.id, version="1.4")
        header.scales = las.header.scales
        header.offsets = las.header.offsets
        if with_crs_in_nodes and crs is not None:
            header.add_crs(crs)
        node = laspy.LasData(header)
        node.points = las.points[sel].copy()
        node.write(str(folder / "ept-data" / f"{key}.laz"))
        hierarchy[key] = int(sel.size)
    (folder / "ept-hierarchy" / "0-0-0-0.json").write_text(json.dumps(hierarchy))
    schema = [{"name": n, "type": "signed", "size": 4, "scale": float(s), "offset": float(o)}
              for n, s, o in zip("XYZ", las.header.scales, las.header.offsets)]
    schema += [{"name": "Intensity", "type": "unsigned", "size": 2},
               {"name": "Classification", "type": "unsigned", "size": 1}]
    doc = {"bounds": cube, "boundsConforming": [*lo, *hi], "dataType": "laszip",
           "hierarchyType": "json", "points": int(x.size), "schema": schema, "span": 128,
           "srs": ({"wkt": crs.to_wkt()} if crs is not None else {}), "version": "1.0.0"}
    (folder / "ept.json").write_text(json.dumps(doc))
    return folder / "ept.json"
