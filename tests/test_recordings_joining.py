"""Recordings end to end (calibench.recordings.joining): no two recordings share a pass, time
never runs back."""

from __future__ import annotations

import numpy as np

from calibench.recordings.joining import labels_end_to_end, times_end_to_end


def test_labels_continue_from_the_previous_recording():
    got = labels_end_to_end([np.array([3.0, 3.0, 7.0]), np.array([0.0, 5.0, 0.0]), np.zeros(2)])
    np.testing.assert_array_equal(got, [0, 0, 1, 2, 3, 2, 4, 4])


def test_times_start_one_step_after_the_previous_recording():
    got = times_end_to_end([np.array([100.0, 102.0, 104.0]), np.array([5.0, 6.0]), np.array([9.0])])
    # the second starts one median step (2 s) after 4 s; the third one step (1 s) after 7 s
    np.testing.assert_allclose(got, [0.0, 2.0, 4.0, 6.0, 7.0, 8.0])
    assert np.all(np.diff(got) > 0)
