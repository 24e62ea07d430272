"""The ADC timing diagram and the in-motion accuracy of each ADC: ``python docs/adc_figure.py`` writes docs/figures/adc.png.

The motion guide's rig (the default robot with a 1 kg handle, its plane
tilted 3 deg; 0.3 m reaches at 3 m/s^2 peak, 1 kHz 16-bit encoders, a
100 N/m hand spring whose pull rises over 0.1 s): for each ADC, a hold-based
static calibration and a free-motion recording through it, then a task
estimated at each conversion (``sailforce.estimate.multirate``) and, side by
side, by a timing-blind pipeline (each cell's latest conversion held and
taken as simultaneous with the angles).  Prints the table the docs quote.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sailforce import (
    OK,
    Handle,
    MotionDataError,
    NoiseModel,
    Plane,
    Robot,
    calibrate,
    calibration_session,
    estimate_moving,
    session_offsets,
)
from sailforce.adc import ADC, PRESETS
from sailforce.estimate import MultiRateEstimator, held_loads
from sailforce.fit import fit_dynamic_term
from sailforce.motion import derivatives, multirate_columns, reaching, record, record_holds, record_multirate

ROBOT = Robot(handle=Handle(mass=1.0), plane=Plane(tilt_deg=3.0))


def accuracy(adc: ADC, offsets) -> dict:
    """RMS force error [N] at force_t_s, the largest age [ms], and the timing-blind pipeline's error, for one ADC."""
    t1, t2, fx, fy, _, _ = calibration_session(ROBOT, seed=2, offsets=offsets)
    holds = record_holds(ROBOT, adc, t1, t2, fx, fy, hold_s=1.0, offsets=offsets, seed=1)
    free = record_multirate(ROBOT, adc, reaches=16, offsets=offsets, seed=3)
    try:
        cal = calibrate(multirate_columns(holds, ("fx_N", "fy_N")), robot=ROBOT, model="matrix", adc=adc,
                        free_motion=multirate_columns(free))  # fmt: skip
    except MotionDataError as exc:
        return {"refused": str(exc).split(":")[0]}
    task = record_multirate(ROBOT, adc, reaches=8, hand_stiffness=100.0, offsets=offsets, seed=7)
    qd, qdd = derivatives(task.t, task.theta, cal.dynamics.differentiator)
    out = MultiRateEstimator(cal).rows(task.t, task.theta, task.loads, task.load_t, np.zeros(task.t.size, bool), qd, qdd)
    c, ok = out.columns, out.status == OK
    ft = c["force_t_s"]
    true = np.column_stack([np.interp(ft, task.t, task.force[:, i]) for i in range(2)])
    err = np.hypot(c["fx_N"] - true[:, 0], c["fy_N"] - true[:, 1])[ok]
    held = held_loads(task.loads)
    bx, by, st, _ = estimate_moving(cal, cal.dynamics, task.t, task.theta[:, 0], task.theta[:, 1], held[:, 0], held[:, 1])
    blind = np.hypot(bx - task.force[:, 0], by - task.force[:, 1])[st == OK]
    return {"rms": float(np.sqrt(np.mean(err**2))), "age_ms": float(1e3 * np.nanmax(task.t - ft)),
            "blind": float(np.sqrt(np.mean(blind**2))), "delay_ms": 1e3 * cal.adc_delay_s}  # fmt: skip


def ideal_accuracy(offsets) -> float:
    t1, t2, fx, fy, counts, _ = calibration_session(ROBOT, seed=2, offsets=offsets)
    cal = calibrate({"theta1_deg": np.degrees(t1), "theta2_deg": np.degrees(t2), "fx_N": fx, "fy_N": fy, "load1": counts[:, 0],
                     "load2": counts[:, 1]}, robot=ROBOT, model="matrix")  # fmt: skip
    free = record(ROBOT, reaching(ROBOT, reaches=16), offsets=offsets, seed=3)
    term = fit_dynamic_term(cal, free.t, free.theta[:, 0], free.theta[:, 1], free.loads[:, 0], free.loads[:, 1]).term
    task = record(ROBOT, reaching(ROBOT, reaches=8), hand_stiffness=100.0, offsets=offsets, seed=7)
    fx_, fy_, st, _ = estimate_moving(cal, term, task.t, task.theta[:, 0], task.theta[:, 1], task.loads[:, 0], task.loads[:, 1])
    return float(np.sqrt(np.mean((np.hypot(fx_ - task.force[:, 0], fy_ - task.force[:, 1])[st == OK]) ** 2)))


def timing_diagram(ax) -> None:
    """Ticks, two HX711s' conversions on their own clocks, their sinc4 windows, and the instant each estimate refers to."""
    adc = PRESETS["hx711-80"]
    rates, phases = (79.1, 80.7), (0.0031, 0.0097)
    start, stop = 0.0, 0.125
    ticks = np.arange(start, stop, 0.001)
    ax.vlines(ticks, -0.15, 0.15, color="0.75", lw=0.6)
    ax.text(stop, 0.0, "  encoder ticks, 1 kHz", va="center", fontsize=8)
    latest = []
    for row, (rate, phase, colour) in enumerate(zip(rates, phases, ("tab:blue", "tab:orange"))):
        y = 1.0 + row
        ready = phase + np.arange(0, 12) / rate
        ready = ready[(ready > 0.05) & (ready < stop)]
        chip = replace(adc, rate_Hz=rate)
        for k, tau in enumerate(ready):
            lags = np.linspace(0.0, chip.settling_s, 200)
            shape = chip.weights(lags) / chip.weights(lags).max() * 0.7
            ax.fill_between(tau - lags, y, y + shape, color=colour, alpha=0.12 if k else 0.3, lw=0)
            ax.plot([tau, tau], [y, y + 0.8], color=colour, lw=1.2)
        ax.plot(ready - chip.group_delay_s, np.full(ready.size, y - 0.08), "v", color=colour, ms=5)
        ax.text(stop, y + 0.3, f"  cell {row + 1}: {rate:g} SPS, sinc4 window {chip.settling_s * 1e3:.0f} ms", va="center", fontsize=8)
        latest.append(ready - chip.group_delay_s)
    c1, c2 = latest
    for k, tau in enumerate(sorted(np.concatenate([c1 + adc.group_delay_s, c2 + adc.group_delay_s]))):
        mine = [c[c <= tau - adc.group_delay_s + 1e-9] for c in latest]
        if all(m.size for m in mine):
            instant, y = min(m[-1] for m in mine), 0.3 + 0.12 * (k % 3)
            ax.annotate("", xy=(instant, y), xytext=(tau, y), arrowprops={"arrowstyle": "->", "color": "tab:green", "lw": 0.8})
            ax.plot(instant, y, "o", color="tab:green", ms=3)
    ax.text(stop, 0.45, "  each conversion: an estimate at force_t_s (the older centroid)", va="center", fontsize=8, color="tab:green")
    ax.set_xlim(start + 0.0, stop)
    ax.set_ylim(-0.3, 3.0)
    ax.set_yticks([])
    ax.set_xlabel("time [s]  (bars: data ready; shaded: the filter's weights; ▼: the window's centroid)")
    ax.set_title("two HX711s at 80 SPS on their own clocks, 1 kHz ticks, and the instant each estimate refers to")


def main(output: Path) -> None:
    offsets = session_offsets(ROBOT, NoiseModel(), 1)
    rows = {name: accuracy(PRESETS[name], offsets) for name in ("hx711-80", "ads1232-80", "nau7802-320", "ads131m02-1000", "hx711-10")}
    ideal = ideal_accuracy(offsets)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 7.5), gridspec_kw={"height_ratios": [1.2, 1]})
    timing_diagram(top)
    names = [n for n, r in rows.items() if "rms" in r]
    index = np.arange(len(names))
    bottom.bar(index - 0.2, [rows[n]["rms"] for n in names], 0.4, color="tab:blue", label="at each conversion (sailforce)")
    bottom.bar(index + 0.2, [rows[n]["blind"] for n in names], 0.4, color="tab:red", label="timing-blind (held, taken as simultaneous)")
    bottom.axhline(ideal, color="0.4", ls="--", lw=0.8, label=f"the ideal sensor (1 kHz, unfiltered): {ideal:.3f} N")
    bottom.set_xticks(index, names)
    bottom.set_yscale("log")
    bottom.set_ylabel("force error, RMS [N]")
    bottom.set_title("a task of 8 reaches (3 m/s², 1 kg handle), each ADC calibrated through itself; hx711-10 refused")
    bottom.legend(fontsize=8)
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=110)
    print(f"ideal sensor: {ideal:.4f} N RMS")
    for name, r in rows.items():
        if "rms" in r:
            print(f"{name:<16} {r['rms']:.4f} N RMS at force_t_s (max age {r['age_ms']:.1f} ms), timing-blind {r['blind']:.3f} N, "
                  f"identified extra delay {r['delay_ms']:+.2f} ms")  # fmt: skip
        else:
            print(f"{name:<16} refused: {r['refused']}")
    print(f"wrote {output}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "figures" / "adc.png")
