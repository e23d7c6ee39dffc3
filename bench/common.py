"""What every part of the benchmark shares: paths, ladders, the error metrics, and JSON files.

The error metrics compare an image with the converged reference, over RGB:

    RMSE   = sqrt(mean((x - r)^2))
    relMSE = mean((x - r)^2 / (r^2 + 1e-2))       (the 1e-2 keeps dark pixels from dominating)
    FLIP   = mean of NVIDIA's FLIP error map (flip-evaluator, LDR), on both images as Blender shows
             them with the Standard view transform: sRGB-encoded and clipped to 0..1
"""
from __future__ import annotations

import hashlib
import json
import os
import sys

import numpy as np

BENCH = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(BENCH)
SCENES_DIR = os.path.join(ROOT, "sample_scenes")
REFS = os.path.join(BENCH, "refs")              # cached Cycles references (gitignored)
OUT = os.path.join(BENCH, "out")                # images and raw measurements of the last run (gitignored)
RESULTS = os.path.join(BENCH, "results")        # the measurements behind REPORT.md (committed)
PLOTS = os.path.join(ROOT, "docs", "images", "bench")
REPORT = os.path.join(BENCH, "REPORT.md")
PERFORMANCE = os.path.join(ROOT, "docs", "performance.md")   # its "## Benchmark" section is generated

for path in (ROOT, os.path.join(ROOT, "tools"), os.path.join(ROOT, "tests")):
    if path not in sys.path:
        sys.path.insert(0, path)

# The relMSE guard: mean((x - r)^2 / (r^2 + GUARD)).
REL_MSE_GUARD = 1e-2
# The headline compares Primer with Cycles at this many samples.
HEADLINE_SAMPLES = 64


# The scenes of the denoise phase: a large area light's soft shadows (direct light, cheap samples) and the
# path-traced Cornell box (costly samples, noisy at few).
DENOISE_SCENES = ("light_area", "cornell_box")


# Sample scenes built to differ from Cycles on purpose: with the lecture's defaults Primer does not converge
# to Cycles there (shading_visibility: Cycles lets light leak through an open smooth sheet, the lecture's
# face-normal rule does not; tests/test_blender_scenes.py, CYCLES_CHOICES), so an error against Cycles
# measures that choice, not noise.
NOT_LIKE_CYCLES = {"shading_visibility"}


# The real phase's scenes (issue 34): files made by other people, fetched into tools/real_scenes.py's cache (never
# committed) and rigged there as its `compare` rigs them, each rendered with direct light and path traced. One per
# class the issue names that this machine can fetch: a Cornell box lit by its emissive quad, a textured glTF model
# under an HDRI, an HDRI still life of metals (98 gold and silver spheres), and an artist's scene lit by several
# emitters (Mike Pan's BMW27 studio: emission panels, a world colour, glass, chrome, flake paint).
REAL_SCENES = ("cornell_box", "gltf_damaged_helmet", "gltf_metal_rough_spheres", "bmw27_studio")
REAL_INTEGRATORS = ("direct", "path")
REAL_SIZE = (240, 180)
# Scenes rendered smaller than REAL_SIZE, to keep the phase's time reasonable: the BMW27's Cycles reference (1024
# samples) takes minutes at 160 x 120 on the shared 2 cores, and 2.25 times as long at 240 x 180.
REAL_SIZES = {"bmw27_studio": (160, 120)}
REAL_PREFIX = "real-"


def real_size(scene: str) -> tuple:
    """(width, height) at which the real scene `scene` (its tools/real_scenes.py name) is rigged for the bench."""
    return REAL_SIZES.get(scene, REAL_SIZE)


def real_name(scene: str, integrator: str) -> str:
    """The bench's name of a real scene rigged for `integrator`: real-SCENE-INTEGRATOR."""
    return f"{REAL_PREFIX}{scene}-{integrator}"


def real_label(name: str) -> tuple:
    """(scene, integrator) of a real phase's name real-SCENE-INTEGRATOR."""
    scene, integrator = name[len(REAL_PREFIX):].rsplit("-", 1)
    return scene, integrator


def blend_of(name: str) -> str:
    """The .blend a bench scene name stands for: sample_scenes/NAME.blend, or a rigged real scene in bench/out/real/."""
    if name.startswith(REAL_PREFIX):
        return os.path.join(OUT, "real", f"{name}.blend")
    return os.path.join(SCENES_DIR, f"{name}.blend")


class Plan:
    """How much `make bench` measures: the full run, or --quick for development."""

    def __init__(self, quick: bool):
        self.quick = quick
        self.reference_samples = 256 if quick else 1024       # Cycles, as two halves with different seeds
        self.primer_ladder = [1, 4, 16, 64] if quick else [1, 2, 4, 8, 16, 32, 64, 128, 256, 512]
        self.cycles_ladder = [4, 16, 64] if quick else [1, 2, 4, 8, 16, 32, 64, 128]
        self.repeats = 1 if quick else 3
        # Primer's samples with and without Render > Denoise (the denoise phase, on DENOISE_SCENES).
        self.denoise_ladder = [1, 4, 16, 64] if quick else [1, 2, 4, 8, 16, 32, 64, 128]
        # Rounds of the rays phase (one Primer render, then embreex on the same rays): this shared
        # machine's steal time moves single rounds by ±30%, so the median needs many.
        self.rays_rounds = 5 if quick else 21
        self.scenes = (["light_point", "light_area", "modifiers_instances"] if quick
                       else sorted(f[:-6] for f in os.listdir(SCENES_DIR)
                                   if f.endswith(".blend") and f[:-6] not in NOT_LIKE_CYCLES))
        # The real phase: its scenes, and shorter ladders with one repeat (a real scene's render takes seconds,
        # its Cycles reference minutes).
        self.real_scenes = ([real_name("cornell_box", "path")] if quick else
                            [real_name(scene, integrator) for scene in REAL_SCENES for integrator in REAL_INTEGRATORS])
        self.real_primer_ladder = [1, 4, 16, 64] if quick else [1, 2, 4, 8, 16, 32, 64, 128, 256]
        self.real_repeats = 1

    def ladders(self, name: str) -> tuple:
        """(Primer's sample counts, Cycles', repeats) of the scene `name`'s ladder."""
        if name.startswith(REAL_PREFIX):
            return self.real_primer_ladder, self.cycles_ladder, self.real_repeats
        return self.primer_ladder, self.cycles_ladder, self.repeats

    def as_dict(self) -> dict:
        """Return the plan as plain values, for the results file."""
        return {"quick": self.quick, "reference_samples": self.reference_samples,
                "primer_ladder": self.primer_ladder, "cycles_ladder": self.cycles_ladder,
                "repeats": self.repeats, "denoise_ladder": self.denoise_ladder, "rays_rounds": self.rays_rounds,
                "scenes": self.scenes, "real_scenes": self.real_scenes, "real_primer_ladder": self.real_primer_ladder,
                "real_repeats": self.real_repeats}


def digest(*parts) -> str:
    """Return a short hex digest of files (given as paths) and JSON-able values, as the Blender tests key their cache."""
    sha = hashlib.sha256()
    for part in parts:
        if isinstance(part, str) and os.path.isfile(part):
            with open(part, "rb") as fh:
                sha.update(fh.read())
        else:
            sha.update(json.dumps(part, sort_keys=True).encode())
        sha.update(b"\0")
    return sha.hexdigest()[:20]


def read_json(path: str, default=None):
    """Return the JSON value stored at `path`, or `default` when there is no such file."""
    if not os.path.isfile(path):
        return default
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def write_json(path: str, value) -> None:
    """Write `value` as indented JSON, atomically (a half-written file never replaces a good one)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path + ".part", "w", encoding="utf-8") as fh:
        json.dump(value, fh, indent=1, sort_keys=True)
    os.replace(path + ".part", path)


# ----------------------------------------------------------------------------
# Error metrics
# ----------------------------------------------------------------------------

def rmse(image: np.ndarray, reference: np.ndarray) -> float:
    """Return sqrt(mean((x - r)^2)) over RGB. image, reference: (H, W, >=3) float."""
    d = image[..., :3].astype(np.float64) - reference[..., :3]
    return float(np.sqrt(np.mean(d * d)))


def rel_mse(image: np.ndarray, reference: np.ndarray) -> float:
    """Return mean((x - r)^2 / (r^2 + 1e-2)) over RGB. image, reference: (H, W, >=3) float."""
    r = reference[..., :3].astype(np.float64)
    d = image[..., :3].astype(np.float64) - r
    return float(np.mean(d * d / (r * r + REL_MSE_GUARD)))


def display(image: np.ndarray) -> np.ndarray:
    """Return RGB as Blender's Standard view shows it: sRGB-encoded, clipped to 0..1: (H, W, 3) float32."""
    from core.film.image_io import linear_to_srgb

    return linear_to_srgb(image[..., :3].astype(np.float64)).astype(np.float32)


def flip(image: np.ndarray, reference: np.ndarray) -> float:
    """Return the mean LDR-FLIP error of the displayed images (0 = identical, 1 = maximal)."""
    import flip_evaluator

    _, mean, _ = flip_evaluator.evaluate(display(reference), display(image), "LDR", inputsRGB=True,
                                         applyMagma=False)
    return float(mean)


def errors(image: np.ndarray, reference: np.ndarray) -> dict:
    """Return every metric of `image` against `reference`: {"rmse", "relmse", "flip"}."""
    return {"rmse": rmse(image, reference), "relmse": rel_mse(image, reference), "flip": flip(image, reference)}


def read_exr(path: str) -> np.ndarray:
    """Read an image with OpenImageIO: (H, W, C) float32, row 0 at the top."""
    from core.film.image_io import read_image

    return read_image(path)
