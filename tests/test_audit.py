"""The seed audit: every verdict pinned, and a deliberately wrong claim is refuted."""

from __future__ import annotations

import pytest

from analytic import systems
from analytic.claims import Claim, doc_frame
from analytic.claims.documents import all_claims
from harness.studies.audit import audit, audit_claim, consistent, format_table

P = systems.symbols("spring")  # the parameters as sympy symbols

# Hand analysis of both documents (see the closing note of the audit issue): claim id -> (verdict, cause)
EXPECTED = {
    "001.spring.T": ("confirmed", ""), "001.spring.U": ("confirmed", ""), "001.spring.L": ("confirmed", ""),
    "001.spring.eom": ("confirmed", ""), "001.spring.omega": ("confirmed", ""),
    "001.spring.solution": ("confirmed", ""),
    "001.pendulum.L": ("refuted", "error"), "001.pendulum.eom_r": ("refuted", "error"),
    "001.pendulum.eom_theta": ("confirmed", ""), "001.pendulum.small_angle_lambda": ("refuted", "error"),
    "001.pendulum.small_angle_eom": ("confirmed", ""),
    "001.general.lambda_sign": ("ambiguous", ""), "001.general.inequality": ("ambiguous", ""),
    "000.spherical.T": ("confirmed", ""), "000.spherical.V": ("ambiguous", ""),
    "000.spherical.L": ("confirmed", ""), "000.spherical.dL_dthetadot": ("confirmed", ""),
    "000.spherical.ddt_dL_dthetadot": ("confirmed", ""), "000.spherical.dL_dtheta": ("confirmed", ""),
    "000.spherical.dL_dphidot": ("confirmed", ""), "000.spherical.ddt_dL_dphidot": ("refuted", "error"),
    "000.spherical.dL_dphi": ("confirmed", ""), "000.spherical.eom_theta": ("refuted", "transcription slip"),
    "000.spherical.eom_phi": ("refuted", "error"), "000.spherical.cyclic": ("confirmed", ""),
    "000.spherical.p_phi": ("confirmed", ""),
    "000.hoop_ramp.rolling": ("confirmed", ""), "000.hoop_ramp.dof": ("confirmed", ""),
    "000.hoop_plane.rolling_x": ("confirmed", ""), "000.hoop_plane.rolling_y": ("confirmed", ""),
    "000.hoop_plane.dof": ("confirmed", ""), "000.hoop_plane.nonholonomic": ("confirmed", ""),
    "000.general.inequality": ("ambiguous", ""),
    "000.atwood.constraint1": ("confirmed", ""), "000.atwood.constraint2": ("confirmed", ""),
    "000.atwood.T": ("confirmed", ""), "000.atwood.V": ("confirmed", ""),
    "000.atwood.dL_dz1": ("confirmed", ""), "000.atwood.dL_dz3dot": ("confirmed", ""),
    "000.atwood.eom1": ("confirmed", ""), "000.atwood.eom2": ("confirmed", ""),
    "000.atwood.eom3": ("confirmed", ""), "000.atwood.z1ddot": ("confirmed", ""),
    "000.atwood.z2ddot": ("confirmed", ""), "000.atwood.z3ddot": ("confirmed", ""),
    "000.atwood.lambda1": ("confirmed", ""), "000.atwood.lambda2": ("refuted", "transcription slip"),
    "000.atwood.tensions": ("confirmed", ""),
}


@pytest.fixture(scope="module")
def rows():
    return {r.claim.id: r for r in audit()}


def test_claim_ids_are_unique_and_all_pinned():
    ids = [c.id for c in all_claims()]
    assert len(ids) == len(set(ids))
    assert set(ids) == set(EXPECTED)


@pytest.mark.parametrize("cid", sorted(EXPECTED))
def test_verdict_is_pinned(rows, cid):
    row = rows[cid]
    assert (row.verdict, row.cause) == EXPECTED[cid]
    assert consistent(row), f"symbolic and numeric disagree: {row}"
    if row.verdict == "refuted":
        assert row.corrected, "a refuted claim must carry its correction"
        if row.numeric_error is not None and not row.claim.numeric_blind:
            assert row.numeric_error > 10 * row.numeric_floor  # the numbers refute it too


def test_deliberately_wrong_claim_is_refuted_by_both_checks():
    f = doc_frame("spring", "q", {"x": "q"})
    (q,), (_qd,) = f.q, f.qd
    wrong = Claim("test.spring.U_wrong", "test", "test", "U = k q^2", f, "value",
                  claimed=P.k * q**2, truth=lambda v: v.V, measure="potential")
    row = audit_claim(wrong)
    assert row.verdict == "refuted" and row.cause == "error"
    assert row.numeric_agrees is False and row.numeric_error > 0.5
    assert "k*q**2/2" in row.corrected


def test_table_lists_every_claim(rows):
    text = format_table(list(rows.values()))
    assert all(cid in text for cid in EXPECTED)
