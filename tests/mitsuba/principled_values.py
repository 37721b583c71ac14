#!/usr/bin/env python3
"""Writes principled_values.csv: Mitsuba 3's own `principled` BSDF values and densities.

For a few parameter sets covering every lobe, at pseudo-random direction pairs (both sides,
reflection and transmission), it records Mitsuba's `eval` (f times the cosine of the
outgoing direction) and `pdf`, in Mitsuba's local frame and naming: `wi` towards the viewer,
`wo` towards the light. `src/bsdf/principled.rs` compares its values with this table.

Run with Mitsuba 3 installed (`pip install mitsuba`), variant llvm_ad_rgb:
    python3 tests/mitsuba/principled_values.py
"""

import os

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
import drjit as dr
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
PARAMS = [
    "base_r",
    "base_g",
    "base_b",
    "roughness",
    "anisotropic",
    "metallic",
    "spec_trans",
    "spec_tint",
    "sheen",
    "sheen_tint",
    "flatness",
    "clearcoat",
    "clearcoat_gloss",
    "eta",
]
SETS = [
    {"base": [0.8, 0.4, 0.2]},
    {
        "base": [0.8, 0.3, 0.2],
        "roughness": 0.7,
        "sheen": 1.0,
        "sheen_tint": 0.5,
        "flatness": 0.5,
    },
    {
        "base": [0.9, 0.7, 0.3],
        "metallic": 0.7,
        "roughness": 0.3,
        "anisotropic": 0.6,
        "spec_tint": 0.6,
    },
    {
        "base": [0.1, 0.3, 0.8],
        "roughness": 0.4,
        "clearcoat": 1.0,
        "clearcoat_gloss": 0.8,
        "eta": 1.7,
    },
    {"base": [0.9, 0.95, 1.0], "spec_trans": 1.0, "roughness": 0.2, "eta": 1.45},
    {
        "base": [0.3, 0.8, 0.4],
        "spec_trans": 0.6,
        "roughness": 0.5,
        "metallic": 0.1,
        "clearcoat": 0.5,
    },
    {
        "base": [0.6, 0.6, 0.9],
        "spec_trans": 0.8,
        "roughness": 0.35,
        "anisotropic": 0.5,
        "spec_tint": 0.4,
    },
]
PAIRS = 48


def directions(rng: np.random.Generator, n: int, upper: bool) -> np.ndarray:
    """Unit vectors, uniform on the sphere (on the upper half when `upper`)."""
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if upper:
        v[:, 2] = np.abs(v[:, 2])
    return v


def main() -> None:
    mi.set_variant("llvm_ad_rgb")
    rng = np.random.default_rng(184)
    rows = []
    for params in SETS:
        d = {"type": "principled"}
        for k, v in params.items():
            if k == "base":
                d["base_color"] = {"type": "rgb", "value": v}
            else:
                d[k] = v
        bsdf = mi.load_dict(d)
        wi = directions(rng, PAIRS, True)
        if params.get("spec_trans", 0.0) > 0.0:
            wi[PAIRS // 2 :, 2] *= -1.0
        wo = directions(rng, PAIRS, False)
        si = dr.zeros(mi.SurfaceInteraction3f, PAIRS)
        si.wi = mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2])
        w = mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])
        ctx = mi.BSDFContext()
        value = np.array(bsdf.eval(ctx, si, w))
        pdf = np.array(bsdf.pdf(ctx, si, w))
        full = {
            "base_r": params["base"][0],
            "base_g": params["base"][1],
            "base_b": params["base"][2],
            "roughness": 0.5,
            "eta": 1.5,
        }
        full.update({k: v for k, v in params.items() if k != "base"})
        for i in range(PAIRS):
            rows.append(
                [full.get(k, 0.0) for k in PARAMS]
                + list(wi[i])
                + list(wo[i])
                + list(value[:, i])
                + [pdf[i]]
            )
    header = PARAMS + [
        "wi_x",
        "wi_y",
        "wi_z",
        "wo_x",
        "wo_y",
        "wo_z",
        "f_r",
        "f_g",
        "f_b",
        "pdf",
    ]
    with open(os.path.join(HERE, "principled_values.csv"), "w") as f:
        f.write(",".join(header) + "\n")
        f.writelines(",".join(f"{x:.9g}" for x in r) + "\n" for r in rows)


if __name__ == "__main__":
    main()
