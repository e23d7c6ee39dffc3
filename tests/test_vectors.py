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


def test_row_picking_and_row_tests_are_numpys_indexing_and_reductions():
    """pick_rows, keep_rows, all_columns and any_nonzero give what numpy's fancy and boolean
    indexing and .all / .any over the last axis give, NaN, infinities, negative zero and empty
    arrays included."""
    rng = np.random.default_rng(7)
    values = rng.normal(size=(200, 3))
    values[rng.random((200, 3)) < 0.2] = 0.0
    values[5] = [np.nan, 0.0, 0.0]
    values[6] = [-0.0, 0.0, np.inf]
    values[7] = [0.0, -0.0, 0.0]
    blocks = rng.normal(size=(200, 3, 3))
    index = rng.integers(0, 200, 500)
    keep = rng.random(200) < 0.6
    for array in (values, blocks, values.astype(np.float32), (values > 0)):
        np.testing.assert_array_equal(vectors.pick_rows(array, index), array[index])
        np.testing.assert_array_equal(vectors.keep_rows(array, keep), array[keep])
    mask = rng.random((200, 3)) < 0.7
    np.testing.assert_array_equal(vectors.all_columns(mask), mask.all(axis=1))
    np.testing.assert_array_equal(vectors.any_nonzero(values), values.any(axis=1))
    empty = np.zeros((0, 3))
    assert vectors.all_columns(empty > 0).shape == (0,)
    assert vectors.any_nonzero(empty).shape == (0,)
    assert vectors.pick_rows(values, np.zeros(0, np.int64)).shape == (0, 3)
