"""The Surrey Face Model as eos loads it, plus numpy copies for the benchmark's own geometry.

Everything is read from eos's own files in ``shapemodel/sfm/`` with eos's own loaders, so the
meshes the benchmark builds from coefficients are eos's (``MorphableModel.draw_sample``); the
numpy arrays are only used for speed where the same sum is needed many times (the synthetic
ground truth), and `SFM.check` verifies they agree with ``draw_sample``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

import eos

FILES = (
    "sfm_shape_3448.bin",
    "expression_blendshapes_3448.bin",
    "ibug_to_sfm.txt",
    "sfm_model_contours.json",
    "sfm_3448_edge_topology.json",
)

# Every other vertex of each 17-vertex outline chain of sfm_model_contours.json, starting at the
# third one (eye height) and ending at the chain's last vertex (next to the chin): chain index
# 2, 4, ..., 16 for iBUG contour landmarks 1..8 (right chain) and 17..10 (left chain, mirrored).
CHAIN_PICK = (2, 4, 6, 8, 10, 12, 14, 16)
RIGHT_CONTOUR_LANDMARKS = tuple(range(1, 9))  # iBUG 1..8 (the subject's right, image left)
LEFT_CONTOUR_LANDMARKS = tuple(range(17, 9, -1))  # iBUG 17..10, same order as the chain


@dataclass
class SFM:
    """eos objects and numpy arrays of the Surrey Face Model (model millimetres)."""

    directory: str
    model: "eos.morphablemodel.MorphableModel"
    mapper: "eos.core.LandmarkMapper"
    edge_topology: "eos.morphablemodel.EdgeTopology"
    contour_landmarks: "eos.fitting.ContourLandmarks"
    model_contour: "eos.fitting.ModelContour"
    mean: np.ndarray  # (3N,) float64
    basis: np.ndarray  # (3N, 63) rescaled PCA basis (orthonormal basis * sqrt(eigenvalues))
    blendshapes: np.ndarray  # (3N, 6)
    expression_names: list
    triangles: np.ndarray  # (T, 3) 0-based vertex indices
    mapping: dict  # iBUG landmark number (1-based) -> vertex index, the 50 mapped ones
    right_chain: list  # 17 vertex indices
    left_chain: list
    edge_faces: np.ndarray  # (E, 2) 0-based triangle indices of edges with two faces
    edge_vertices: np.ndarray  # (E, 2) 0-based vertex indices of those edges
    hole_loops: list  # border loops other than the outer one (the mouth), each (K, 2) edges

    @property
    def num_vertices(self) -> int:
        return self.mean.size // 3

    def instance(self, shape, expression) -> np.ndarray:
        """Vertices (N, 3) for shape coefficients (SD units) and expression weights (numpy)."""
        v = self.mean + self.basis @ np.asarray(shape, float) + self.blendshapes @ np.asarray(expression, float)
        return v.reshape(-1, 3)

    def eos_instance(self, shape, expression) -> np.ndarray:
        """Vertices (N, 3) built by eos itself: ``MorphableModel.draw_sample``."""
        mesh = self.model.draw_sample([float(x) for x in shape], [float(x) for x in expression], [])
        return np.asarray(mesh.vertices, dtype=float)

    def check(self) -> float:
        """Largest difference (mm) between the numpy instance and eos's draw_sample on a sample."""
        rng = np.random.default_rng(7)
        a = rng.standard_normal(self.basis.shape[1])
        e = rng.uniform(0, 1, self.blendshapes.shape[1])
        return float(np.abs(self.instance(a, e) - self.eos_instance(a, e)).max())


def _pairs(items) -> np.ndarray:
    return np.array([[d["value0"], d["value1"]] for d in items], dtype=np.int64)


def load(directory: str) -> SFM:
    for f in FILES:
        if not os.path.isfile(os.path.join(directory, f)):
            raise FileNotFoundError(os.path.join(directory, f))
    p = lambda f: os.path.join(directory, f)  # noqa: E731
    shape_only = eos.morphablemodel.load_model(p("sfm_shape_3448.bin"))
    blendshapes = eos.morphablemodel.load_blendshapes(p("expression_blendshapes_3448.bin"))
    model = eos.morphablemodel.MorphableModel(
        shape_only.get_shape_model(),
        blendshapes,
        color_model=eos.morphablemodel.PcaModel(),
        vertex_definitions=None,
        texture_coordinates=shape_only.get_texture_coordinates(),
    )
    mapper = eos.core.LandmarkMapper(p("ibug_to_sfm.txt"))
    sm = model.get_shape_model()
    mapping = {int(k): int(v) for k, v in mapper.get_mappings().items()}
    contours = json.load(open(p("sfm_model_contours.json")))["model_contour"]
    # eos's edge topology is 1-based (Matlab); 0 marks a border edge with only one face.
    topo = json.load(open(p("sfm_3448_edge_topology.json")))["edge_topology"]
    faces = _pairs(topo["adjacent_faces"])
    verts = _pairs(topo["adjacent_vertices"])
    inner = (faces > 0).all(axis=1)
    loops = _border_loops(verts[~inner] - 1)
    loops.sort(key=len)
    return SFM(
        directory=directory,
        model=model,
        mapper=mapper,
        edge_topology=eos.morphablemodel.load_edge_topology(p("sfm_3448_edge_topology.json")),
        contour_landmarks=eos.fitting.ContourLandmarks.load(p("ibug_to_sfm.txt")),
        model_contour=eos.fitting.ModelContour.load(p("sfm_model_contours.json")),
        mean=np.asarray(sm.get_mean(), dtype=float),
        basis=np.asarray(sm.get_rescaled_pca_basis(), dtype=float),
        blendshapes=np.stack([np.asarray(b.deformation, dtype=float) for b in blendshapes], axis=1),
        expression_names=[b.name for b in blendshapes],
        triangles=np.asarray(sm.get_triangle_list(), dtype=np.int64),
        mapping=dict(sorted(mapping.items())),
        right_chain=list(contours["right_contour"]),
        left_chain=list(contours["left_contour"]),
        edge_faces=faces[inner] - 1,
        edge_vertices=verts[inner] - 1,
        hole_loops=loops[:-1],  # all but the longest (the face's outer border)
    )


def _border_loops(edges: np.ndarray) -> list:
    """Connected groups of border edges (edges with one face)."""
    parent = {}

    def find(x):
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in edges:
        parent[find(a)] = find(b)
    groups = {}
    for e in edges:
        groups.setdefault(find(e[0]), []).append(e)
    return [np.array(g) for g in groups.values()]
