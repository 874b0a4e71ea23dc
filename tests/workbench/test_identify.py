"""Identifiability (`workbench.diagnosis.identify`) against subspaces whose
principal angles are known by construction, and the findings it changes."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from workbench.diagnosis.findings import findings
from workbench.diagnosis.identify import (PARALLEL_COS, largest_cosine, noise_weights, not_separable, partners,
                                          principal_cosines)
from workbench.diagnosis.result import Candidate, FamilyDiagnosis

# orthonormal bases and an SVD: rounding only
EXACT = 1e-12
angles = st.floats(0.0, math.pi / 2, allow_nan=False)


def _e(n, *ks):
    out = np.zeros((n, len(ks)))
    for j, k in enumerate(ks):
        out[k, j] = 1.0
    return out


@settings(max_examples=50, deadline=None)
@given(a=angles, b=angles, scale=st.floats(1e-3, 1e3), seed=st.integers(0, 2 ** 31 - 1))
def test_principal_cosines_of_planes_rotated_by_known_angles(a, b, scale, seed):
    """span(e1, e2) against span(cos a e1 + sin a e3, cos b e2 + sin b e4):
    principal cosines cos a and cos b, whatever the columns' scale and mix,
    and whatever common rotation of the space."""
    e1, e2, e3, e4 = _e(6, 0, 1, 2, 3).T
    A = np.column_stack([e1, e2])
    B = np.column_stack([math.cos(a) * e1 + math.sin(a) * e3, math.cos(b) * e2 + math.sin(b) * e4])
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    # an invertible mix of condition at most 2 (a random normal one can be near
    # singular, its weaker direction then below the basis's 1 % tolerance): same column space
    R, _ = np.linalg.qr(rng.normal(size=(2, 2)))
    mix = R @ np.diag([1.0, 1.0 + rng.uniform()])
    c = principal_cosines(Q @ A * scale, Q @ B @ mix)
    assert_allclose(c, sorted([math.cos(a), math.cos(b)], reverse=True), atol=1e-9)
    assert_allclose(largest_cosine(Q @ A, Q @ B), max(math.cos(a), math.cos(b)), atol=1e-9)


def test_a_line_inside_a_plane_is_parallel_and_orthogonal_spaces_are_not():
    plane = _e(5, 0, 1)
    assert_allclose(largest_cosine(plane, np.array([[3.0], [4.0], [0], [0], [0]])), 1.0, atol=EXACT)
    assert_allclose(largest_cosine(plane, _e(5, 2, 3)), 0.0, atol=EXACT)
    assert largest_cosine(plane, np.zeros((5, 1))) == 0.0


def test_noise_weights_favour_well_measured_components_and_clip_zero_floors():
    """Two patterns that agree on a well-measured component and disagree on a
    noisy one are parallel once weighted; a zero floor weighs as 10 % of the RMS floor."""
    A = np.array([[1.0], [1.0]])
    B = np.array([[1.0], [-1.0]])
    assert_allclose(largest_cosine(A, B), 0.0, atol=EXACT)
    # the 0.001 m floor clipped to 10 % of the RMS floor: weights k : 1, cosine (k^2 - 1) / (k^2 + 1)
    k = 1.0 / (0.1 * math.sqrt(0.5 * (0.001 ** 2 + 1.0)))
    assert_allclose(largest_cosine(A, B, noise_weights([0.001, 1.0])), (k * k - 1) / (k * k + 1), rtol=1e-12)
    f = np.array([0.0, 1.0, 1.0])
    assert_allclose(noise_weights(f), 1.0 / np.maximum(f, 0.1 * math.sqrt(2 / 3)), rtol=EXACT)


def test_not_separable_names_only_the_parallel_pairs():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(40, 2))
    b = np.column_stack([a[:, 0] + 1e-3 * rng.normal(size=40)])     # inside a's span, but for a little noise
    c = rng.normal(size=(40, 1))
    pairs = not_separable({"a": a, "b": b, "c": c}, np.ones(40))
    assert [p["effects"] for p in pairs] == [["a", "b"]]
    assert pairs[0]["cosine"] >= PARALLEL_COS


def _family(gap_b: float, pairs):
    top = Candidate("drogue_drag", ["drogue_drag"], 1, params={"drogue_drag": {"scale": 0.5}},
                    param_stderr={"drogue_drag": {"scale": 0.05}}, gap_before=0.3, gap_after_heldout=0.100,
                    shrink_heldout=2 / 3, probability=0.55)
    other = Candidate("hose_drag", ["hose_drag"], 1, params={"hose_drag": {"crossflow": 2.0}},
                      param_stderr={"hose_drag": {"crossflow": 0.2}}, gap_before=0.3, gap_after_heldout=gap_b,
                      shrink_heldout=1 - gap_b / 0.3, probability=0.40)
    none = Candidate("none", [], 0, gap_after_heldout=0.3, probability=0.05)
    return FamilyDiagnosis(family="trail/kdc10/kdc10_pod", kind="trail", logs=["a"], n_elements=20,
                           gap_definition="", gap_before=0.3, noise_floor=0.01, gap_real=True, held_out_scheme="",
                           screen={}, not_applicable={}, ranking=[top, other, none], failed=[],
                           remaining_unexplained={"gap_m": 0.1, "above_noise_m": 0.0995}, gap={},
                           gap_after_best={}, wall_s=1.0, not_separable=pairs)


def test_findings_give_both_parallel_explanations_with_their_probabilities():
    pair = [{"effects": ["hose_drag", "drogue_drag"], "cosine": 0.99}]
    d = _family(0.105, pair)         # within the 0.01 m noise floor of the top's held-out gap
    assert [c.effect for c, _ in partners(d)] == ["hose_drag"]
    text = "\n".join(findings(d))
    assert "cannot tell apart: drogue_drag" in text and "probability 0.55" in text
    assert "or hose_drag" in text and "probability 0.40" in text
    assert "Not separable on these logs" in text and "hose_drag and drogue_drag (0.990)" in text
    assert d.to_json()["not_separable"] == pair


def test_a_parallel_partner_whose_gap_is_beyond_the_noise_leaves_one_best_explanation():
    d = _family(0.150, [{"effects": ["drogue_drag", "hose_drag"], "cosine": 0.99}])
    assert partners(d) == []
    text = "\n".join(findings(d))
    assert "Best explanation: drogue_drag" in text and "cannot tell apart" not in text
    assert partners(_family(0.105, [])) == []
