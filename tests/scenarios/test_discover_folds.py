"""Held-out blocks that fit the recording (issue 36): along a path, interleaved blocks, so that
no fold holds out a whole region; in random order, contiguous fifths as before."""

import numpy as np

from calibench.scenarios.discover.folds import (
    INTERLEAVED_BLOCKS,
    N_FOLDS,
    block_folds,
    follows_a_path,
)


def _path(n=400):
    s = np.linspace(0, 1, n)
    return np.c_[np.cos(7 * s), np.sin(5 * s), s]  # a smooth curve through the workspace


def test_a_path_is_held_out_in_interleaved_blocks_that_leave_no_region_out():
    p = _path()
    assert follows_a_path(p)
    fold, words = block_folds(p, "poses")
    assert "interleaved" in words and "path" in words
    n = len(p)
    for k in range(N_FOLDS):
        held = np.flatnonzero(fold == k)
        # every fold's held-out rows spread along the whole path: a block in every stretch of
        # N_FOLDS blocks, from the start to the end
        stretch = N_FOLDS * n // INTERLEAVED_BLOCKS
        assert held.min() < stretch and held.max() >= n - stretch
        assert np.diff(held).max() <= stretch - n // INTERLEAVED_BLOCKS + 1
    # neighbours stay together: a block's samples share their fold
    assert np.mean(fold[1:] == fold[:-1]) > 1 - 1.5 * INTERLEAVED_BLOCKS / n


def test_samples_in_random_order_keep_contiguous_fifths():
    rng = np.random.default_rng(1)
    p = rng.permutation(_path())
    assert not follows_a_path(p)
    fold, words = block_folds(p, "poses")
    assert words == "five contiguous blocks of poses"
    assert np.all(np.diff(fold) >= 0) and set(fold) == set(range(N_FOLDS))
