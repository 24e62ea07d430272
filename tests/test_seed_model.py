"""What was the seed's model? The families' machinery and the three checks, against analytic laws and our own study."""

from __future__ import annotations

import numpy as np
import pytest

from sailforce.io.robotkeys import with_keys
from sailforce.paper.seed import seed_table4
from sailforce.paper.seed_model import (
    Family,
    fit_families,
    implied_torque_amplitudes,
    interior_minimum,
    phase_drivers,
    phase_pattern,
    pin_crosstalk,
)
from sailforce.paper.study import run_study, table4
from sailforce.robot import Robot

#: The cot-delta law is exact in the frame: only rounding remains.
LAW_TOL = 1e-9
#: implied_torque_amplitudes evaluates Table 4 regressors (R^2 > 0.999, extrapolated to 127.5 deg), not the exact table.
REGRESSOR_TOL = 0.01
#: A noise-free family fit recovers its parameters.
RECOVERY_RTOL = 1e-6


def test_pin_joints_without_crosstalk_are_exact():
    check = pin_crosstalk(Robot(), crosstalk=0.0)
    assert check.a1_spread < LAW_TOL and check.a2_spread < LAW_TOL
    assert check.p1_max_deg < LAW_TOL and max(map(abs, check.p2_range_deg)) < LAW_TOL


@pytest.mark.parametrize("c", [0.02, -0.05])
def test_axial_crosstalk_scales_cell_1_by_one_over_one_minus_c_cot_delta(c):
    """N1 = -V1 cot(delta): cell 1 reads V1 (1 - c cot delta), in phase; cell 2 gains a phase offset."""
    check = pin_crosstalk(Robot(), crosstalk=c)
    assert check.a1_spread > 0.05
    assert check.a1_corrected_spread < LAW_TOL
    assert check.p1_max_deg < LAW_TOL
    assert min(map(abs, check.p2_range_deg)) > 0.5


def test_bonded_phases_follow_geometry_more_than_stiffness():
    rows = {label: (p1, p2) for label, p1, p2 in phase_drivers(Robot())}
    base = rows.pop("as given")
    stiffness = [v for k, v in rows.items() if "compliance" in k or "link E" in k]
    geometry = [v for k, v in rows.items() if k.startswith(("l2", "l3", "cell position"))]
    for column in (0, 1):
        moved_by_stiffness = max(abs(v[column] - base[column]) for v in stiffness)
        moved_by_geometry = max(abs(v[column] - base[column]) for v in geometry)
        assert moved_by_geometry > 1.5 * moved_by_stiffness


def test_phase_pattern_is_free_of_the_convention():
    seed = seed_table4()
    flipped = seed.copy()
    flipped[:, [2, 4]] *= -1.0
    a, b = phase_pattern(seed), phase_pattern(flipped)
    assert a.convention_free_match and b.convention_free_match
    assert a.signs == (1, -1) and b.signs == (-1, 1)
    shrinking = seed[::-1].copy()
    assert not phase_pattern(shrinking).convention_free_match


def test_seed_amplitudes_fall_then_rise():
    seed = seed_table4()
    assert interior_minimum(seed, 1) and interior_minimum(seed, 2)
    monotone = seed.copy()
    monotone[:, 1] = np.linspace(1.0, 2.0, len(seed))
    assert not interior_minimum(monotone, 1)


@pytest.mark.parametrize("transduction", ["deflection", "bridge"])
def test_implied_lengths_recover_our_own_study(transduction):
    """The seed-lengths inference, applied to a study whose lengths we know, gives them back."""
    result = run_study(with_keys(Robot(), {"joints.model": "bonded"}), transduction)
    regressors = {name: fit.coefficients for name, fit in result.regressors.items()}
    implied = implied_torque_amplitudes(regressors, result.prescale, (result.rmse_before.t1, result.rmse_before.t2),
                                        result.protocol)  # fmt: skip
    np.testing.assert_allclose(implied, result.torque_amplitude, rtol=REGRESSOR_TOL)


def test_a_family_recovers_the_robot_that_made_the_table():
    truth = with_keys(Robot(), {"joints.model": "spring", "joints.stiffness": 300.0, "links.l3": 0.5})
    family = Family("spring", "shared spring and l3", ("joints.stiffness", "links.l3"), fixed={"joints.model": "spring"})
    (fit,) = fit_families(Robot(), table4(truth), (family,))
    np.testing.assert_allclose(fit.fit.values, [300.0, 0.5], rtol=RECOVERY_RTOL)
    assert fit.meets_targets and fit.score < 1e-3
    np.testing.assert_allclose(fit.table, table4(truth), atol=1e-6)


# --- the fits' pool and cache -------------------------------------------------------------------------------

#: Two families, fitted in a second or two: enough to see order, pool and cache at work.
_CHEAP = (Family("spring", "shared spring and l3", ("joints.stiffness", "links.l3"), fixed={"joints.model": "spring"}),
          Family("spring, phases", "the same, phases only", ("joints.stiffness", "links.l3"),
                 fixed={"joints.model": "spring"}, amplitude_weight=0.0))  # fmt: skip


def _truth_table():
    return table4(with_keys(Robot(), {"joints.model": "spring", "joints.stiffness": 300.0, "links.l3": 0.5}))


def test_the_pool_fits_what_this_process_fits():
    """The starts and polishes as pool tasks are the tasks identify runs in turn: the same numbers, bit for bit."""
    here = fit_families(Robot(), _truth_table(), _CHEAP, workers=1)
    pooled = fit_families(Robot(), _truth_table(), _CHEAP, workers=2)
    for a, b in zip(here, pooled):
        assert a.family == b.family
        np.testing.assert_array_equal(a.fit.values, b.fit.values)
        np.testing.assert_array_equal(a.fit.residuals, b.fit.residuals)
    from sailforce.errors import InputError

    with pytest.raises(InputError, match="workers = 0: expected at least 1"):
        fit_families(Robot(), _truth_table(), _CHEAP, workers=0)


def test_the_fit_cache_answers_a_rerun_and_only_its_own_fit(tmp_path, monkeypatch):
    import sailforce.io.cache as cache_module

    fresh = fit_families(Robot(), _truth_table(), _CHEAP, workers=1, cache_dir=tmp_path)
    assert not any(f.cached for f in fresh) and len(list(tmp_path.glob("*.json"))) == len(_CHEAP)
    notes: list[str] = []
    again = fit_families(Robot(), _truth_table(), _CHEAP, workers=1, cache_dir=tmp_path, notes=notes)
    assert all(f.cached for f in again) and notes == []
    for a, b in zip(fresh, again):
        np.testing.assert_array_equal(a.fit.values, b.fit.values)
        np.testing.assert_array_equal(a.fit.standard_errors, b.fit.standard_errors)
        assert a.seconds == b.seconds  # the time the fit took when it was made
    # another target, another robot, other code: each is a fit of its own
    other = _truth_table()
    other[:, 2] += 0.1
    assert not any(f.cached for f in fit_families(Robot(), other, _CHEAP[:1], workers=1, cache_dir=tmp_path))
    start = with_keys(Robot(), {"links.l3": 0.4})
    assert not any(f.cached for f in fit_families(start, _truth_table(), _CHEAP[:1], workers=1, cache_dir=tmp_path))
    monkeypatch.setattr(cache_module, "_FINGERPRINT", "0" * 64)
    assert not any(f.cached for f in fit_families(Robot(), _truth_table(), _CHEAP[:1], workers=1, cache_dir=tmp_path))


def test_a_damaged_or_forged_fit_entry_is_fitted_again_with_a_note(tmp_path):
    import hashlib
    import json

    from sailforce.io.cache import _canonical

    fresh = fit_families(Robot(), _truth_table(), _CHEAP[:1], workers=1, cache_dir=tmp_path)
    (entry,) = tmp_path.glob("*.json")
    data = json.loads(entry.read_text())
    # forged: other parameters under a valid checksum; the residuals evaluated afresh give it away
    data["value"]["x"] = [v + 0.01 for v in data["value"]["x"]]
    data.pop("sha256")
    data["sha256"] = hashlib.sha256(_canonical(data)).hexdigest()
    entry.write_text(json.dumps(data))
    notes: list[str] = []
    refit = fit_families(Robot(), _truth_table(), _CHEAP[:1], workers=1, cache_dir=tmp_path, notes=notes)
    assert not refit[0].cached and len(notes) == 1 and "residuals are not those of its parameters" in notes[0]
    np.testing.assert_array_equal(refit[0].fit.values, fresh[0].fit.values)
    # damaged: a byte changed
    entry.write_text(entry.read_text().replace('"x":[', '"x":[1,', 1))
    notes.clear()
    assert not fit_families(Robot(), _truth_table(), _CHEAP[:1], workers=1, cache_dir=tmp_path, notes=notes)[0].cached
    assert len(notes) == 1 and "checksum" in notes[0]
