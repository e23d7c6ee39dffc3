"""Write core/materials/thin_film_table.h: the spectral sensitivities that thin-film iridescence reads
(core/materials/thin_film.py says how they enter).

A thin film's reflectance oscillates with the wavelength; an RGB renderer needs, per channel c, its mean
over the spectrum weighed by that channel's colour-matching function cbar(lambda). Belcour and Barla
(2017) write the film's reflectance as a Fourier series in the phase 2 pi OPD / lambda, so each term
needs only the channel's sensitivity to one optical path difference OPD (nm):

    S_c(OPD) = integral cbar(lambda) cos(2 pi OPD / lambda) dlambda / integral cbar(lambda) dlambda

(the real part of the Fourier transform of the matching function in 1 / lambda, normalised so S_c(0) = 1;
films on metal also need its imaginary part, -integral cbar sin(2 pi OPD / lambda) / integral cbar). cbar is
the linear Rec.709 (scene-linear) matching function, the CIE 1931 2-degree observer's xbar, ybar, zbar through
the XYZ (D65) to Rec.709 matrix, integrated here on a 0.25 nm grid of the 5 nm table, linearly interpolated. The table holds S at TABLE_SIZE optical path
differences i * OPD_MAX / (TABLE_SIZE - 1), the range and spacing of Cycles' own table (60 um / 2 pi);
beyond OPD_MAX the sensitivities are below 1e-3 and the lookups clamp.

    .venv/bin/python tools/thin_film_table.py      # rewrites core/materials/thin_film_table.h (a second)
"""
from __future__ import annotations

import math
import os

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "core", "materials", "thin_film_table.h")
TABLE_SIZE = 512
OPD_MAX = 60000.0 / (2.0 * math.pi)

# CIE 1931 2-degree colour-matching functions, 5 nm steps: (wavelength nm, xbar, ybar, zbar).
CIE_1931 = np.array([
    (360, 0.0001299, 0.000003917, 0.0006061),
    (365, 0.0002321, 0.000006965, 0.001086),
    (370, 0.0004149, 0.00001239, 0.001946),
    (375, 0.0007416, 0.00002202, 0.003486),
    (380, 0.001368, 0.000039, 0.006450001),
    (385, 0.002236, 0.000064, 0.01054999),
    (390, 0.004243, 0.00012, 0.02005001),
    (395, 0.00765, 0.000217, 0.03621),
    (400, 0.01431, 0.000396, 0.06785001),
    (405, 0.02319, 0.00064, 0.1102),
    (410, 0.04351, 0.00121, 0.2074),
    (415, 0.07763, 0.00218, 0.3713),
    (420, 0.13438, 0.004, 0.6456),
    (425, 0.21477, 0.0073, 1.0390501),
    (430, 0.2839, 0.0116, 1.3856),
    (435, 0.3285, 0.01684, 1.62296),
    (440, 0.34828, 0.023, 1.74706),
    (445, 0.34806, 0.0298, 1.7826),
    (450, 0.3362, 0.038, 1.77211),
    (455, 0.3187, 0.048, 1.7441),
    (460, 0.2908, 0.06, 1.6692),
    (465, 0.2511, 0.0739, 1.5281),
    (470, 0.19536, 0.09098, 1.28764),
    (475, 0.1421, 0.1126, 1.0419),
    (480, 0.09564, 0.13902, 0.8129501),
    (485, 0.05795001, 0.1693, 0.6162),
    (490, 0.03201, 0.20802, 0.46518),
    (495, 0.0147, 0.2586, 0.3533),
    (500, 0.0049, 0.323, 0.272),
    (505, 0.0024, 0.4073, 0.2123),
    (510, 0.0093, 0.503, 0.1582),
    (515, 0.0291, 0.6082, 0.1117),
    (520, 0.06327, 0.71, 0.07824999),
    (525, 0.1096, 0.7932, 0.05725001),
    (530, 0.1655, 0.862, 0.04216),
    (535, 0.2257499, 0.9148501, 0.02984),
    (540, 0.2904, 0.954, 0.0203),
    (545, 0.3597, 0.9803, 0.0134),
    (550, 0.4334499, 0.9949501, 0.008749999),
    (555, 0.5120501, 1, 0.005749999),
    (560, 0.5945, 0.995, 0.0039),
    (565, 0.6784, 0.9786, 0.002749999),
    (570, 0.7621, 0.952, 0.0021),
    (575, 0.8425, 0.9154, 0.0018),
    (580, 0.9163, 0.87, 0.001650001),
    (585, 0.9786, 0.8163, 0.0014),
    (590, 1.0263, 0.757, 0.0011),
    (595, 1.0567, 0.6949, 0.001),
    (600, 1.0622, 0.631, 0.0008),
    (605, 1.0456, 0.5668, 0.0006),
    (610, 1.0026, 0.503, 0.00034),
    (615, 0.9384, 0.4412, 0.00024),
    (620, 0.8544499, 0.381, 0.00019),
    (625, 0.7514, 0.321, 0.0001),
    (630, 0.6424, 0.265, 0.00004999999),
    (635, 0.5419, 0.217, 0.00003),
    (640, 0.4479, 0.175, 0.00002),
    (645, 0.3608, 0.1382, 0.00001),
    (650, 0.2835, 0.107, 0),
    (655, 0.2187, 0.0816, 0),
    (660, 0.1649, 0.061, 0),
    (665, 0.1212, 0.04458, 0),
    (670, 0.0874, 0.032, 0),
    (675, 0.0636, 0.0232, 0),
    (680, 0.04677, 0.017, 0),
    (685, 0.0329, 0.01192, 0),
    (690, 0.0227, 0.00821, 0),
    (695, 0.01584, 0.005723, 0),
    (700, 0.01135916, 0.004102, 0),
    (705, 0.008110916, 0.002929, 0),
    (710, 0.005790346, 0.002091, 0),
    (715, 0.004109457, 0.001484, 0),
    (720, 0.002899327, 0.001047, 0),
    (725, 0.00204919, 0.00074, 0),
    (730, 0.001439971, 0.00052, 0),
    (735, 0.0009999493, 0.0003611, 0),
    (740, 0.0006900786, 0.0002492, 0),
    (745, 0.0004760213, 0.0001719, 0),
    (750, 0.0003323011, 0.00012, 0),
    (755, 0.0002348261, 0.0000848, 0),
    (760, 0.0001661505, 0.00006, 0),
    (765, 0.000117413, 0.0000424, 0),
    (770, 0.00008307527, 0.00003, 0),
    (775, 0.00005870652, 0.0000212, 0),
    (780, 0.00004150994, 0.00001499, 0),
    (785, 0.00002935326, 0.0000106, 0),
    (790, 0.00002067383, 0.0000074657, 0),
    (795, 0.00001455977, 0.0000052578, 0),
    (800, 0.00001025398, 0.0000037029, 0),
    (805, 0.000007221456, 0.0000026078, 0),
    (810, 0.000005085868, 0.0000018366, 0),
    (815, 0.000003581652, 0.0000012934, 0),
    (820, 0.000002522525, 0.00000091093, 0),
    (825, 0.000001776509, 0.00000064153, 0),
    (830, 0.000001251141, 0.00000045181, 0),
])

# Linear CIE XYZ (D65 white) to linear Rec.709 (sRGB primaries).
XYZ_TO_REC709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                          [-0.9692660, 1.8760108, 0.0415560],
                          [0.0556434, -0.2040259, 1.0572252]])


def matching_functions(step: float = 0.25):
    """(wavelengths (m,) nm, Rec.709 matching functions (m, 3)) on a grid of `step` nm over the CIE table."""
    lam = np.arange(CIE_1931[0, 0], CIE_1931[-1, 0] + 0.5 * step, step)
    xyz = np.stack([np.interp(lam, CIE_1931[:, 0], CIE_1931[:, k]) for k in (1, 2, 3)], axis=1)
    return lam, xyz @ XYZ_TO_REC709.T


def sensitivity(opd: np.ndarray, step: float = 0.25) -> np.ndarray:
    """S_c at optical path differences opd (n,) nm: (n, 3) float64, 1 at opd = 0 (module docstring)."""
    lam, cbar = matching_functions(step)
    phase = np.cos(2.0 * math.pi * np.asarray(opd, np.float64)[:, None] / lam[None, :])
    return (phase @ cbar) / cbar.sum(axis=0)


def sensitivity_imaginary(opd: np.ndarray, step: float = 0.25) -> np.ndarray:
    """The imaginary parts (n, 3) of the same transform, -integral cbar sin(2 pi OPD / lambda) / integral cbar:
    what a film on metal needs, whose faces shift the phase by other angles than 0 and pi."""
    lam, cbar = matching_functions(step)
    phase = np.sin(2.0 * math.pi * np.asarray(opd, np.float64)[:, None] / lam[None, :])
    return -(phase @ cbar) / cbar.sum(axis=0)


def main() -> None:
    """Compute the table and write the header."""
    table = sensitivity(np.linspace(0.0, OPD_MAX, TABLE_SIZE))
    lines = ["/* Generated by tools/thin_film_table.py; do not edit. Thin-film sensitivities "
             "(core/materials/thin_film.py). */",
             "", "#define THIN_FILM_TABLE_SIZE %d" % TABLE_SIZE, "#define THIN_FILM_OPD_MAX %.17g" % OPD_MAX, "",
             "/* S[channel][i], 3 x %d: Rec.709 channel sensitivity to the optical path difference "
             "i * OPD_MAX / %d nm */" % (TABLE_SIZE, TABLE_SIZE - 1),
             "static const double THIN_FILM_S[%d] = {" % (3 * TABLE_SIZE)]
    flat = table.T.reshape(-1)
    for start in range(0, len(flat), 8):
        lines.append("    " + ", ".join("%.9g" % v for v in flat[start:start + 8]) + ",")
    lines += ["};", "", "/* S_IM[channel][i], 3 x %d: the imaginary parts (films on metal) */" % TABLE_SIZE,
              "static const double THIN_FILM_S_IM[%d] = {" % (3 * TABLE_SIZE)]
    flat = sensitivity_imaginary(np.linspace(0.0, OPD_MAX, TABLE_SIZE)).T.reshape(-1)
    for start in range(0, len(flat), 8):
        lines.append("    " + ", ".join("%.9g" % (v + 0.0) for v in flat[start:start + 8]) + ",")
    lines.append("};")
    with open(OUT, "w") as handle:
        handle.write("\n".join(lines) + "\n")
    print("wrote", OUT)


if __name__ == "__main__":
    main()
