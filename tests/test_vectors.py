"""The small-matrix algebra of core/vectors.py against its definitions (and numpy's LAPACK path)."""
import numpy as np

from core import vectors


def test_cross_product_is_numpys_bit_for_bit():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(1000, 3)) * 1e3, rng.normal(size=(1000, 3)) * 1e-3
    a[0] = (np.nan, 1.0, 2.0)
    b[1] = (np.inf, 0.0, 1.0)
    assert np.array_equal(vectors.cross(a, b), np.cross(a, b), equal_nan=True)
    # The right-handed basis: x cross y = z.
    assert np.array_equal(vectors.cross(np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])), [[0.0, 0.0, 1.0]])


def test_cofactor_inverse_undoes_the_matrix():
    rng = np.random.default_rng(5)
    L = rng.normal(size=(200, 3, 3))
    L[0] = np.diag([2.0, -3.0, 0.5])                              # a mirror: det = -3
    det, inverse = vectors.determinant_and_inverse(L)
    assert det[0] == -3.0
    assert np.allclose(det, np.linalg.det(L), rtol=1e-10, atol=1e-12)
    assert np.allclose(np.einsum("kij,kjl->kil", L, inverse), np.eye(3), atol=1e-9)
    assert np.array_equal(vectors.determinant(L), det)


def test_singular_matrix_has_zero_determinant():
    L = np.array([[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]]])    # rows 1 and 2 parallel
    det, inverse = vectors.determinant_and_inverse(L)
    assert det[0] == 0.0 and not np.isfinite(inverse).all()
