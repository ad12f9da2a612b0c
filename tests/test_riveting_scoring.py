"""Table 5 scoring on hand-worked cases (bands from the seed's Table 5, worse-of-two reading)."""

import numpy as np
import pytest

from wbik.apps.riveting.scoring import band, localisation_points, rivet_points, score


@pytest.mark.parametrize(("mm", "deg", "points"), [
    (0.0, 0.0, 10), (0.29, 0.99, 10),
    (0.3, 0.0, 5),            # 0.3 mm is not "< 0.3 mm"
    (0.1, 1.0, 5),            # 1 deg is not "< 1 deg"
    (0.1, 2.0, 5), (1.5, 0.5, 5),
    (1.6, 0.5, 2), (0.1, 3.5, 2), (5.0, 5.0, 2),
    (5.01, 0.0, 0), (0.0, 5.01, 0), (12.0, 0.0, 0),
    (0.2, 4.0, 2),            # worse of (10, 2)
])
def test_localisation_bands(mm, deg, points):
    assert localisation_points(mm, deg) == points


@pytest.mark.parametrize(("rivets", "points"),
                         [(0, 0), (4, 0), (5, 2), (9, 2), (10, 5), (14, 5), (15, 10), (33, 10)])
def test_rivet_bands(rivets, points):
    assert rivet_points(rivets) == points


def test_band_edges():
    assert [band(v, (1.0, 2.0, 3.0)) for v in (0.5, 1.0, 2.0, 2.5, 3.0, 3.5)] == [0, 1, 1, 2, 2, 3]


def test_thesis_result_scores_22():
    # Table 6: zero localisation error, 9 rivets, no collision -> 10 + 2 + 10
    result = score([0.0] * 9, [0.0] * 9, rivets=9, collisions=0)
    assert (result.localisation, result.rivets, result.collisions, result.total) == (10, 2, 10, 22)


def test_full_marks_and_collision_penalty():
    assert score([1e-4] * 15, [np.radians(0.5)] * 15, 15, 0).total == 30
    assert score([1e-4] * 15, [np.radians(0.5)] * 15, 15, 1).total == 20


def test_mean_error_is_averaged_before_banding():
    # errors 0.1 and 0.7 mm: mean 0.4 mm -> 5 points (not the best or worst single rivet)
    assert score([1e-4, 7e-4], [0.0, 0.0], 2, 0).localisation == 5


def test_no_rivet_no_localisation_points():
    assert score([], [], 0, 0).total == 10
