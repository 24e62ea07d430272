/*
 * libsail: end-effector force from two link-integrated load cells (SAIL),
 * in portable C99 for the robot's microcontroller.
 *
 * The same estimator as sailforce's Python `Calibration.estimate`
 * (src/sailforce/estimate/estimator.py; with real ADCs, src/sailforce/estimate/multirate.py); calibrations come from `sail calibrate`
 * and are turned into C initializers by `sail export-c`.
 *
 * No malloc, no globals, no I/O.  Angles in radians, counter-clockwise from
 * +x; loads in the calibration's raw unit (HX711 counts, mV/V or N); forces
 * in newtons.
 *
 * sail_real is float unless SAIL_DOUBLE is defined (CMake: -DSAIL_DOUBLE=ON);
 * a calibration header must be compiled with the same choice as the library
 * (sail_calibration_real_size() tells at run time).
 *
 * The core equations (docs/errata.md for the departures from the seed paper):
 *
 *   static estimate   F = M(theta1, theta2)^-1 (s - offset),   s = (load1, load2)
 *                     M = C(delta) J^T (SAIL_MODEL_MATRIX) or rows R(-P_i) j_i / A_i (SAIL_MODEL_SEED),
 *                     J^T = [[-l3 sin th1, l3 cos th1], [-l2 sin th2, l2 cos th2]]   (seed Eqs. 3, 4, 7),
 *                     solved by Cramer's rule; singular where |sin(theta1 - theta2)| < SAIL_SINGULAR_SIN_DELTA
 *                     (det J = -l2 l3 sin(delta), seed Eq. 9);
 *   in motion         F = M^-1 (s - offset) - w,   J^T w = (l1 V1, l2 V2)   (V: the cells' dynamic shears);
 *   real ADCs         per conversion of cell i, its filter's window averaged:  u_i = r_i - offset_i - sum_j w_j d_i(t_j)
 *                     = (sum_j w_j M_i(q_j)) F(c_i), solved at the older cell's window centroid (sail_multirate_step);
 *   low-pass          per second-order section (transposed direct form II, as scipy.signal.sosfilt):
 *                     y[n] = b0 x[n] + z1;  z1 = b1 x[n] - a1 y[n] + z2;  z2 = b2 x[n] - a2 y[n],
 *                     with CMSIS-DSP's arm_biquad_cascade_df2T coefficients {b0, b1, b2, -a1, -a2}
 *                     (`sail export-c` writes them as <name>_lowpass_df2T).
 *
 * As in CMSIS-DSP, the init and check functions validate; the per-sample functions trust:
 * check a calibration once with sail_calibration_check() before estimating with it.
 */
#ifndef SAIL_H
#define SAIL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#ifdef SAIL_DOUBLE
typedef double sail_real;
#else
typedef float sail_real;
#endif

#define SAIL_VERSION_MAJOR 0
#define SAIL_VERSION_MINOR 1

/* Statuses: the codes of sailforce.status, in its order.  When several apply, the first
 * of INVALID, SINGULAR, SATURATED, MOTION_UNKNOWN, EXTRAPOLATED wins.  sail_force.status
 * holds one as an int32_t, so that the struct's layout does not depend on the compiler. */
enum sail_status {
    SAIL_OK,            /* estimate given */
    SAIL_SINGULAR,      /* |sin(theta1 - theta2)| < SAIL_SINGULAR_SIN_DELTA: fx, fy are NaN */
    SAIL_SATURATED,     /* |load - offset| beyond a cell's capacity: estimate given, not to be trusted */
    SAIL_EXTRAPOLATED,  /* delta outside the calibrated range: estimate given */
    SAIL_INVALID,       /* a field is NaN or infinite: fx, fy are NaN */
    SAIL_MOTION_UNKNOWN /* with a dynamic term: the joint rates are not known (start, gap): fx, fy are NaN */
};

/* sin(2 deg): sailforce.SINGULAR_SIN_DELTA (src/sailforce/statics.py). */
#define SAIL_SINGULAR_SIN_DELTA 0.03489949670250097
/* 0.01 deg [rad]: sailforce.estimate.estimator.DELTA_RANGE_SLACK. */
#define SAIL_DELTA_RANGE_SLACK 1.7453292519943296e-4

/* Polynomial terms per series: Chebyshev order <= 23 (matrix model; a physics
 * calibration's map over 15..165 deg needs 15-20) and power-series order <= 23
 * (seed model). */
#define SAIL_MAX_TERMS 24
/* Second-order sections of the low-pass filter: Butterworth order <= 8. */
#define SAIL_MAX_SECTIONS 4

/* A literal in a generated calibration: explicit, so float builds take it without a warning. */
#define SAIL_REAL(x) ((sail_real)(x))

/* The sensing model kinds that `sail calibrate` produces. */
enum sail_model_kind {
    /* M = C(delta) J^T, C a Chebyshev series in x = (2 delta - (lo + hi)) / (hi - lo)
     * (sailforce.sensing.MatrixCompensator). */
    SAIL_MODEL_MATRIX = 1,
    /* The seed paper's compensator: row i of M is R(-P_i) j_i / A_i, with j_i
     * row i of J^T and A_i, P_i power series in delta [deg], P_i in degrees
     * (sailforce.sensing.AmplitudePhaseCompensator). */
    SAIL_MODEL_SEED = 2
};

/* SAIL_MODEL_MATRIX's parameters. */
typedef struct {
    int32_t n_terms;                         /* Chebyshev terms (order + 1), 1..SAIL_MAX_TERMS */
    sail_real cheb_lo, cheb_hi;              /* delta [rad] mapped onto x = -1 and +1 */
    sail_real cheb[SAIL_MAX_TERMS][2][2];    /* C(delta) = sum_k cheb[k] T_k(x): signal per unit torque */
} sail_matrix_model;

/* SAIL_MODEL_SEED's parameters: power series, highest power first, delta in degrees. */
typedef struct {
    int32_t amplitude_terms[2];              /* 1..SAIL_MAX_TERMS each */
    int32_t phase_terms[2];
    sail_real amplitude[2][SAIL_MAX_TERMS];  /* A_i: predicted torque per signal unit */
    sail_real phase_deg[2][SAIL_MAX_TERMS];  /* P_i [deg] */
} sail_seed_model;

/* A calibration.  Instances are generated by `sail export-c`; to re-tare at
 * run time, copy one into RAM and set its offsets (sail_tare_finish).
 * `kind` tags which member of `model` holds the parameters. */
typedef struct sail_calibration {
    int32_t kind;              /* enum sail_model_kind */
    sail_real l2, l3;          /* link lengths [m]: J^T rows l3 (-sin th1, cos th1), l2 (-sin th2, cos th2) (seed Eq. 4) */
    sail_real offset[2];       /* raw reading of each cell at no load */
    sail_real capacity[2];     /* |load - offset| beyond this is saturated [raw] */
    sail_real delta_min;       /* calibrated range of delta = theta1 - theta2 [rad] */
    sail_real delta_max;
    union {
        sail_matrix_model matrix;  /* kind == SAIL_MODEL_MATRIX */
        sail_seed_model seed;      /* kind == SAIL_MODEL_SEED */
    } model;
} sail_calibration;

typedef struct { sail_real theta1, theta2, load1, load2; } sail_reading; /* rad, raw units */
typedef struct { sail_real fx, fy; int32_t status; } sail_force;         /* N; status: enum sail_status */

/* What sail_calibration_check, the init functions and sail_tare_finish return. */
enum sail_check {
    SAIL_CHECK_OK = 0,
    SAIL_CHECK_NULL,       /* a NULL pointer */
    SAIL_CHECK_KIND,       /* kind is not a SAIL_MODEL_* */
    SAIL_CHECK_TERMS,      /* a term count outside 1..SAIL_MAX_TERMS */
    SAIL_CHECK_RANGE,      /* cheb_lo >= cheb_hi, delta_min >= delta_max, or either not finite */
    SAIL_CHECK_GEOMETRY,   /* l2 or l3 not positive and finite */
    SAIL_CHECK_CAPACITY,   /* a capacity not positive, or an offset not finite */
    SAIL_CHECK_SECTIONS,   /* a low-pass with n_sections outside 1..SAIL_MAX_SECTIONS */
    SAIL_CHECK_DYNAMICS,   /* a dynamic term with half outside 1..SAIL_MAX_HALF_WINDOW, order outside
                              0..SAIL_MAX_RATE_ORDER, or dt not positive */
    SAIL_CHECK_TOO_FEW,    /* sail_tare_finish: fewer than two finite readings seen */
    SAIL_CHECK_ADC,        /* sail_multirate_init: a period or tick not positive and finite, a delay not within a
                              period, a sinc order outside 1..SAIL_MAX_SINC_ORDER, a window longer than
                              SAIL_MAX_TICKS ticks, or a tick that is not the dynamic term's dt */
    SAIL_CHECK_POLICY      /* sail_rezero_init: a window or quiet limit not positive, blocks outside
                              1..SAIL_REZERO_MAX_BLOCKS, or not 0 <= min_step <= max_step <= max_total */
};

/* SAIL_CHECK_OK, or the first problem found (enum sail_check).  sail_estimate reads the
 * per-model arrays up to the term counts: a calibration that fails here must not be used. */
enum sail_check sail_calibration_check(const sail_calibration *cal);

/* The force for one reading; returns out->status.  fx, fy are NaN when the
 * status is SAIL_SINGULAR or SAIL_INVALID (and for a calibration of unknown
 * kind, reported as SAIL_INVALID). */
enum sail_status sail_estimate(const sail_calibration *cal, const sail_reading *in, sail_force *out);

/* sail_estimate over a block of n readings; returns how many are SAIL_OK. */
size_t sail_estimate_block(const sail_calibration *cal, const sail_reading *in, sail_force *out, size_t n);

/* sizeof(sail_real) the library was built with: 4 (float) or 8 (double). */
size_t sail_calibration_real_size(void);

/* ---- tare: new offsets from a no-load recording (cf. `sail tare`) ------------------------ */

typedef struct {
    uint32_t count;       /* finite readings seen */
    double mean[2];       /* running mean of load1, load2 (Welford; double even in float builds) */
    double m2[2];         /* running sum of squared deviations */
} sail_tare_state;

void sail_tare_init(sail_tare_state *state);
/* Accumulate a block; readings with a non-finite load are skipped. */
void sail_tare_process(sail_tare_state *state, const sail_reading *in, size_t n);
/* Set cal->offset to the means and spread[i] to the sample standard
 * deviations (spread may be NULL).  Returns SAIL_CHECK_OK, or (cal untouched)
 * SAIL_CHECK_TOO_FEW when fewer than two readings were seen, SAIL_CHECK_NULL for a
 * NULL state or calibration. */
enum sail_check sail_tare_finish(const sail_tare_state *state, sail_calibration *cal, sail_real spread[2]);

/* ---- low-pass filter on the loads (cf. sailforce.estimate.LowPass) ----------------------- */

/* A Butterworth low-pass as second-order sections (scipy.signal.butter,
 * output="sos"), generated by `sail export-c --lowpass-hz ... --sample-rate-hz ...`. */
typedef struct sail_lowpass {
    int32_t n_sections;
    sail_real sos[SAIL_MAX_SECTIONS][6];  /* b0 b1 b2 a0 a1 a2, a0 == 1 */
    sail_real zi[SAIL_MAX_SECTIONS][2];   /* steady state for a unit input (scipy.signal.sosfilt_zi) */
} sail_lowpass;

typedef struct {
    const sail_lowpass *design;
    int32_t started;                              /* the state is set from the first valid reading */
    sail_real state[2][SAIL_MAX_SECTIONS][2];     /* per load cell, transposed direct form II */
} sail_lowpass_state;

/* Returns SAIL_CHECK_OK, or SAIL_CHECK_NULL / SAIL_CHECK_SECTIONS (the state is then unusable). */
enum sail_check sail_lowpass_init(sail_lowpass_state *state, const sail_lowpass *design);
/* Filter load1 and load2 of a block in place.  A reading with any
 * non-finite field is skipped (it neither enters nor advances the filter)
 * and its loads become NaN, so sail_estimate reports it SAIL_INVALID. */
void sail_lowpass_process(sail_lowpass_state *state, sail_reading *block, size_t n);

/* ---- force in motion: the dynamic term (cf. sailforce.calibration.inertial, sailforce.motion.dynamics) ------ */

/* Half the longest rate window [samples]: a 0.1 s window at up to 1.28 kHz. */
#define SAIL_MAX_HALF_WINDOW 64
/* Highest order of the rate filter's polynomial (its moments stay within 64 bits). */
#define SAIL_MAX_RATE_ORDER 4
/* A time step longer than this many sampling periods (or not positive) restarts the window:
 * sailforce.motion.differentiate.GAP_FACTOR. */
#define SAIL_GAP_FACTOR 3.0
/* Angles enter the rate filter as whole counts of 2 pi / 2^24 rad (0.08 arc-seconds): exact
 * for any encoder of up to 24 bits, whose angles are whole multiples of it. */
#define SAIL_COUNTS_PER_TURN 16777216.0

/* The identified dynamic term and the rate filter, generated by `sail export-c` for a
 * calibration with a dynamic term (`sail calibrate --free-motion`) at a given sample rate.
 * The cells' dynamic shears (sailforce.motion.dynamics.ShearModel, d = theta1 - theta2):
 *   V1 = k[0][0] a1 + k[0][1] w1^2 + k[0][2] (a2 cos d + w2^2 sin d) + k[0][3] (w2^2 cos d - a2 sin d)
 *        + k[0][4] cos theta1 + k[0][5] sin theta1
 *   V2 = k[1][0] a2 + k[1][1] w2^2 + k[1][2] (a1 cos d - w1^2 sin d) + k[1][3] (a1 sin d + w1^2 cos d)
 *        + k[1][4] cos theta2 + k[1][5] sin theta2
 * and F = M^-1 (s - offset) - w with J^T w = (l1 V1, l2 V2).
 * The rates are Savitzky-Golay fits over a centred window of 2 half + 1 samples: with the
 * window's angles x_j in counts (j = -half..half),
 *   omega = rad_per_count * sum_j (sum_k rate[k] j^k) x_j   (alpha likewise with accel)
 * (sailforce.motion.differentiate.kernel_polynomials). */
typedef struct sail_dynamics {
    sail_real l1, l2;                         /* the cells' moment arms: link lengths [m] */
    sail_real k[2][6];                        /* shear coefficients [N per unit] */
    double dt;                                /* sampling period [s] */
    int32_t half;                             /* half the rate window [samples]: the output's delay */
    int32_t order;                            /* the rate filter's polynomial order, <= SAIL_MAX_RATE_ORDER
                                                 (rate and accel are zero beyond it) */
    double rate[SAIL_MAX_RATE_ORDER + 1];     /* rate kernel polynomial [1/s] */
    double accel[SAIL_MAX_RATE_ORDER + 1];    /* acceleration kernel polynomial [1/s^2] */
} sail_dynamics;

/* The estimate with the dynamic term for one reading whose joint rates w [rad/s] and
 * accelerations a [rad/s^2] are known (measured, or from sail_motion_step); returns
 * out->status.  inertial (may be NULL) receives the subtracted load in raw units, NaN when
 * not computed.  Non-finite rates give SAIL_MOTION_UNKNOWN (unless a static status
 * outranks it) and fx, fy NaN. */
enum sail_status sail_estimate_moving(const sail_calibration *cal, const sail_dynamics *dyn, const sail_reading *in,
                                      sail_real omega1, sail_real omega2, sail_real alpha1, sail_real alpha2,
                                      sail_force *out, sail_real inertial[2]);

/* The causal Savitzky-Golay rate filter over a window of 2 half + 1 samples (docs/dynamics.md).  Angles enter in
 * whole counts and the filter keeps exact integer moments of the window in the binomial basis,
 *   U_k = sum_u C(u, k) x_u   (u = 0..2 half, oldest first),
 * which slide by one sample in O(order) whatever the window's length.  A rate is read on the window's discrete
 * orthogonal (Gram) polynomials t_d: the projections P_d = sum_u t_d(u) x_u = sum_k gram[d][k] U_k are exact
 * integers whatever the angle's level, and omega = sum_d gamma_rate[d] P_d in sail_real loses nothing to
 * cancellation (a float build is within about 1e-6 of the exact rates).  Every counter is bounded: the state runs
 * for ever. */
typedef struct {
    int32_t width;                                        /* 2 half + 1 */
    int32_t order;                                        /* the kernels' polynomial order */
    int32_t slot;                                         /* the ring slot the next sample goes to */
    int32_t run;                                          /* linked samples since the last break, up to width */
    sail_real gamma_rate[SAIL_MAX_RATE_ORDER];            /* the rate kernel on t_1..t_order [rad/s per count] */
    sail_real gamma_accel[SAIL_MAX_RATE_ORDER];           /* the acceleration kernel [rad/s^2 per count] */
    uint32_t entry[SAIL_MAX_RATE_ORDER + 1];              /* C(2 half + 1, k) */
    uint32_t gram[SAIL_MAX_RATE_ORDER][SAIL_MAX_RATE_ORDER + 1];  /* t_{d+1}(u) = sum_k (-1)^(d+1+k) gram[d][k] C(u, k) */
    uint64_t moment[2][SAIL_MAX_RATE_ORDER + 1];          /* U_k of each angle, exact (modulo 2^64) */
    int32_t counts[2 * SAIL_MAX_HALF_WINDOW + 1][2];      /* the window's angles in counts, a ring */
} sail_rate_filter;

/* An instant as the estimators keep it: seconds, or, in float builds for an ARM core without double-precision
 * hardware (a Cortex-M4F), a whole number of 2^-32 s, so that times need no software double arithmetic there
 * (SAIL_FIXED_TIME; sail_math.h's sail_time_fixed).  Times must then lie within +-2^30 s (34 years). */
#if !defined(SAIL_DOUBLE) && defined(__arm__) && !(defined(__ARM_FP) && (__ARM_FP & 8))
#define SAIL_FIXED_TIME 1
typedef int64_t sail_instant;
#else
typedef double sail_instant;
#endif

/* The rate filter and a delay line: each reading comes out `half` samples after it went in, when its centred
 * window is complete (the same numbers as sailforce's offline estimate, which centres the window on each sample).
 * Sampling must be uniform at dyn->dt. */
typedef struct {
    const sail_dynamics *dyn;
    sail_rate_filter rates;
    int32_t pending;                                      /* readings held, not yet returned */
    sail_instant t_last;                                  /* time of the last valid reading */
    sail_real gap;                                        /* SAIL_GAP_FACTOR dt [s] */
    sail_reading held[2 * SAIL_MAX_HALF_WINDOW + 1];      /* the window's readings, a ring (the filter's slots) */
} sail_motion_state;

/* Returns SAIL_CHECK_OK, or SAIL_CHECK_NULL / SAIL_CHECK_DYNAMICS (the state is then unusable; also for kernels
 * that do not sum to zero, which are not derivatives). */
enum sail_check sail_motion_init(sail_motion_state *state, const sail_dynamics *dyn);
/* Push the reading taken at time t [s].  Returns 0 for the first `half` pushes; after that, 1,
 * with *out (and inertial, may be NULL) the estimate of the reading pushed `half` calls
 * earlier, returned in *held (may be NULL).  A step in t that is not positive or exceeds
 * SAIL_GAP_FACTOR dt, or a non-finite time or angle, restarts the window: readings within
 * half a window of it come out SAIL_MOTION_UNKNOWN. */
int sail_motion_step(sail_motion_state *state, const sail_calibration *cal, double t, const sail_reading *in,
                     sail_force *out, sail_real inertial[2], sail_reading *held);
/* At the end of a recording: the oldest reading still held, its motion unknown.  Returns 1
 * while there is one, then 0. */
int sail_motion_flush(sail_motion_state *state, const sail_calibration *cal, sail_force *out,
                      sail_real inertial[2], sail_reading *held);

/* ---- real ADCs: each cell's conversions now and then, through its filter (cf. sailforce.estimate.multirate) ---- */

/* A delta-sigma bridge ADC (an HX711 at 80 SPS, say) converts on its own clock, and its sinc^N decimator makes each
 * conversion the average of the input over the last N periods, weighted by the cardinal B-spline of order N
 * (docs/reference/adc.md).  The estimator takes the encoders at every control tick and each cell's conversion when
 * one is ready; at each conversion it averages the sensing map and the dynamic term over the filter's window, and
 * solves for the force at the older of the two cells' latest window centroids, force_t:
 *   u_i = r_i - offset_i - sum_j w_j d_i(t_j) = (sum_j w_j M_i(q_j)) F(c_i),   c_i = tau_i - delay - N T_i / 2,
 * the other cell's u and averaged row interpolated to force_t (docs/reference/multirate.md).  Each chip's period T_i
 * is measured from its conversions (the mean of its last SAIL_PERIOD_MEMORY intervals). */

/* The longest filter: sinc^8. */
#define SAIL_MAX_SINC_ORDER 8
/* Control ticks the estimator remembers: at 1 kHz, 256 hold an HX711 at 80 SPS (a 50 ms window) with room to spare;
 * a slower ADC or a faster tick needs more (compile the library and its users with -DSAIL_MAX_TICKS=...). */
#ifndef SAIL_MAX_TICKS
#define SAIL_MAX_TICKS 256
#endif
/* The conversions' windows take the sensing map M and the dynamic term d from every k-th control tick (the ring's
 * slots that are multiples of k, "knots"), k the largest power of two up to SAIL_TICK_STRIDE that leaves at least
 * SAIL_KNOTS_PER_PERIOD knots in a conversion period; the ticks between knots carry only their flags, so every tick
 * still decides whether a window is whole, and the rates, M and d of three ticks in four are never computed.  Float
 * builds (the MCU's) take up to 4: an HX711 at 80 SPS with 1 kHz ticks gets k = 4 (12 or 13 knots in its 50 ms
 * window), which takes a Cortex-M4F's tick from about 1,475 instructions to about 950.  What it costs: the window's
 * average of d keeps more of d's content near the knots' rate (the rates' noise), which an every-tick window averages
 * out: in the shared vectors' reaches the force moves by 1.4 mN RMS and 4.5 mN at worst, against the HX711's 4.4 mN
 * of noise at the hand (docs/reference/libsail.md).  Double builds take 1: sailforce's every-tick formulation, within
 * 1e-15.  A pose singular only between two knots is not seen by the window (the estimate's own pose test at force_t
 * still is).  A power of two that divides SAIL_MAX_TICKS. */
#ifndef SAIL_TICK_STRIDE
#ifdef SAIL_DOUBLE
#define SAIL_TICK_STRIDE 1
#else
#define SAIL_TICK_STRIDE 4
#endif
#endif
#if SAIL_TICK_STRIDE < 1 || (SAIL_TICK_STRIDE & (SAIL_TICK_STRIDE - 1)) != 0 || SAIL_MAX_TICKS % SAIL_TICK_STRIDE != 0
#error "SAIL_TICK_STRIDE must be a power of two that divides SAIL_MAX_TICKS"
#endif
/* Knots a conversion period keeps at least: a sinc^N window then has 3 N or more. */
#define SAIL_KNOTS_PER_PERIOD 3
/* Conversion intervals a chip's period is measured over: sailforce.estimate.multirate.PERIOD_MEMORY. */
#define SAIL_PERIOD_MEMORY 16
/* An interval beyond this many nominal periods is a missed conversion: MISSED_CONVERSION. */
#define SAIL_MISSED_CONVERSION 1.5
/* A tick step beyond this many control periods inside a window is a gap: GAP_STEPS. */
#define SAIL_GAP_STEPS 2.5
/* Conversions each cell keeps for the interpolation to force_t: HISTORY. */
#define SAIL_HISTORY 8

/* The ADC, generated by `sail export-c --sample-rate-hz` for a calibration with one (its [adc] table). */
typedef struct sail_adc {
    double period;        /* the nominal conversion period T [s] */
    int32_t sinc_order;   /* N: each conversion averages the last N T */
    double delay;         /* the filter's delay beyond the model, identified by the free-motion fit [s]; within a period */
    double tick;          /* the control period: the encoders' ticks [s] */
} sail_adc;

/* One control tick in: the encoders, and each cell's conversion if one became ready since the last tick. */
typedef struct {
    double t;                  /* the tick [s] */
    sail_real theta1, theta2;  /* [rad] */
    sail_real load[2];         /* each cell's new conversion [raw]; NaN: none this tick */
    double ready[2];           /* its data-ready time [s] when the firmware stamps it; NaN: the tick's own */
} sail_tick;

/* One control tick out: the latest estimate, and the instant it refers to. */
typedef struct {
    sail_real fx, fy;          /* N; NaN when the status is SAIL_SINGULAR, SAIL_INVALID or SAIL_MOTION_UNKNOWN */
    int32_t status;            /* enum sail_status */
    sail_real inertial[2];     /* the dynamic part subtracted from each cell at force_t [raw]: NaN where unknown, 0
                                  without a dynamic term */
    double force_t;            /* the instant the force refers to [s]: t - force_t is its age; NaN before the first */
} sail_timed_force;

/* A processed tick, as the estimator keeps it (times relative to the state's epoch). */
typedef struct {
    sail_real t;               /* [s] after epoch; an invalid tick repeats the last valid time */
    sail_real theta[2];        /* [rad] */
    sail_real v[2][3];         /* per cell: its row of the sensing map M, and the dynamic term's reading [raw] (0
                                  without a dynamic term) */
    uint8_t flags;             /* what is wrong with it: SAIL_TICK_* (sail_multirate.c) */
} sail_adc_tick;

/* One cell's recent conversions. */
typedef struct {
    sail_real centroid[SAIL_HISTORY];  /* the window's centroid [s after epoch] */
    sail_real u[SAIL_HISTORY];         /* reading - offset - averaged dynamic term */
    sail_real row[SAIL_HISTORY][2];    /* the averaged row of M */
    sail_real dynamic[SAIL_HISTORY];   /* the averaged dynamic term */
    sail_real raw[SAIL_HISTORY];       /* the reading */
    uint8_t known[SAIL_HISTORY];       /* the window's ticks were all known */
    int32_t count, newest;             /* conversions held (up to SAIL_HISTORY), the newest's slot */
    sail_real interval[SAIL_PERIOD_MEMORY];  /* the last conversion intervals [s], a ring */
    int32_t intervals, next_interval;
    sail_instant last_ready;           /* the last conversion's data-ready time */
    int32_t converted;                 /* whether it has had one */
} sail_adc_cell;

typedef struct {
    const sail_adc *adc;
    const sail_dynamics *dyn;          /* NULL: no dynamic term (and no delay) */
    const sail_calibration *cal;
    sail_rate_filter rates;
    int32_t pending;                   /* ticks held for the rate window */
    sail_real t_last;                  /* the last valid tick [s after epoch] */
    sail_real gap;                     /* SAIL_GAP_FACTOR dt: the rate filter's break */
    sail_tick held[2 * SAIL_MAX_HALF_WINDOW + 1];
    sail_real held_t[2 * SAIL_MAX_HALF_WINDOW + 1];  /* their times [s after epoch] */
    double epoch;                      /* stored times are relative to it [s] */
    sail_instant epoch_instant;        /* the same, as an instant */
    sail_instant delay_instant;        /* adc->delay, as an instant's difference */
    int32_t has_epoch;                 /* set by the first finite time */
    sail_real spline[SAIL_MAX_SINC_ORDER + 2][SAIL_MAX_SINC_ORDER];  /* B_N on [s, s + 1) as spline[s + 1]: powers
                                                                      of x - s, highest first (zero outside) */
    sail_real tick_gap;                /* SAIL_GAP_STEPS ticks [s] */
    int32_t ticks, newest;             /* ticks held (up to SAIL_MAX_TICKS), the newest's slot */
    int32_t knot_mask;                 /* the knots' stride less one (SAIL_TICK_STRIDE): slot & knot_mask is 0 at a knot */
    sail_adc_tick tick[SAIL_MAX_TICKS];
    sail_adc_cell cell[2];
    sail_timed_force current;          /* the latest estimate */
} sail_multirate_state;

/* Returns SAIL_CHECK_OK, or SAIL_CHECK_NULL, SAIL_CHECK_DYNAMICS (as sail_motion_init; dyn may be NULL: no dynamic
 * term), SAIL_CHECK_ADC (the state is then unusable).  With dyn, adc->tick must be dyn->dt. */
enum sail_check sail_multirate_init(sail_multirate_state *state, const sail_calibration *cal, const sail_dynamics *dyn,
                                    const sail_adc *adc);
/* Push one control tick.  With a dynamic term the rates need half a window of ticks after each one, so the tick
 * that comes out is the one pushed dyn->half calls earlier: returns 0 until then, then 1 with *out its estimate and
 * *held (may be NULL) the tick itself.  Without one, every call returns 1 for the tick just pushed.  A tick whose
 * time or angles are not numbers is SAIL_INVALID on its own row (the estimate it would carry lives on). */
int sail_multirate_step(sail_multirate_state *state, const sail_tick *in, sail_timed_force *out, sail_tick *held);
/* At the end of a recording: the oldest tick still held, its motion unknown.  Returns 1 while there is one, then 0. */
int sail_multirate_flush(sail_multirate_state *state, sail_timed_force *out, sail_tick *held);

/* ---- temperature: the cells' zero and span per degree (cf. sailforce.drift.TemperatureCompensation) ---- */

/* Generated by `sail export-c` for a calibration whose data spanned temperatures (NAME_temperature). */
typedef struct {
    sail_real reference_C;     /* the temperature the calibration refers to [degC] */
    sail_real zero_per_C[2];   /* each cell's zero shift [raw / degC] */
    sail_real span_per_C[2];   /* each cell's span change [1 / degC] */
} sail_temperature;

/* The reading's loads as they would read at the reference temperature, before sail_estimate:
 *   load_i = o_i + (load_i - o_i - zero_i dT) / (1 + span_i dT),   dT = celsius - reference_C.
 * A temperature that is not a number makes the loads NaN (the estimate is then SAIL_INVALID). */
void sail_temperature_correct(const sail_temperature *t, const sail_calibration *cal, sail_reading *r, sail_real celsius);

/* ---- automatic re-zero: each release of the handle is a free tare (cf. sailforce.estimate.rezero) ---- */

/* The estimate is affine in the loads, so offsets that moved by D move it by F(o + D), the estimate of a reading
 * o + D at the same angles: the corrected force is F - F(o + D) (one more sail_estimate per row).  Time is cut into
 * blocks of window_s / blocks; a block is free when each of its rows is SAIL_OK and, with a contact sensor, says
 * free.  At the end of each block the last `blocks` blocks form the window; when all are free and consecutive and
 * the corrected force wanders by at most quiet_N there (sqrt(var fx + var fy)), nobody holds the handle, and the
 * offsets move by W(q)^-1 of the window's mean corrected force, so that it would have read zero: made when that
 * step is at least min_step_N, refused when it is over max_step_N (a steady hand, a knock) or when the offsets would
 * be more than max_total_N from the calibration's as force (re-tare or recalibrate).  The next decision waits for a
 * window wholly under the new offsets.  docs/reference/drift.md. */

/* The most blocks a window is judged in. */
#define SAIL_REZERO_MAX_BLOCKS 16

typedef struct {
    double window_s;           /* a free, quiet window this long [s] */
    int32_t blocks;            /* judged in this many blocks, 1..SAIL_REZERO_MAX_BLOCKS */
    double quiet_N;            /* the corrected force's wander over the window at most [N] */
    double min_step_N;         /* a re-zero moves the estimate by at least this [N] */
    double max_step_N;         /* and at most this [N] */
    double max_total_N;        /* the offsets stay within this of the calibration's, as force [N] */
} sail_rezero_policy;

/* sailforce.estimate.rezero.ReZeroPolicy's defaults. */
#define SAIL_REZERO_POLICY_DEFAULT {2.0, 8, 0.08, 0.01, 1.5, 5.0}

/* What a row's contact sensor says (sail_rezero_step): none fitted, free, or held (or unknown). */
#define SAIL_CONTACT_NONE (-1)
#define SAIL_CONTACT_FREE 0
#define SAIL_CONTACT_HELD 1

enum sail_rezero_decision {
    SAIL_REZERO_NONE = 0,      /* no decision at this row */
    SAIL_REZERO_MADE,          /* the offsets moved: from the next row on */
    SAIL_REZERO_REFUSED_STEP,  /* a quiet window, but its step is over max_step_N */
    SAIL_REZERO_REFUSED_TOTAL  /* a quiet window, but the offsets would be over max_total_N away */
};

typedef struct {
    int64_t index;             /* floor((t - t0) / block) */
    double n;                  /* free rows summed */
    double sums[6];            /* corrected fx, fy, their squares; raw fx, fy */
    sail_real theta[2];        /* the last free row's angles */
    int32_t free;
} sail_rezero_block;

typedef struct {
    double t;                  /* the window's end [s]: the new offsets begin on the next row */
    int32_t decision;          /* enum sail_rezero_decision */
    sail_real delta[2];        /* the offsets' change from the calibration's, after it [raw] */
    double step_N, total_N;    /* |mean corrected F| and |mean raw F| over the window [N] */
} sail_rezero_event;

typedef struct {
    const sail_calibration *cal;
    sail_rezero_policy policy;
    double block_s;
    sail_real delta[2];        /* the offsets' change from the calibration's [raw] */
    double t0;
    int32_t started, in_block;
    sail_rezero_block block;   /* the block being filled */
    sail_rezero_block window[SAIL_REZERO_MAX_BLOCKS];  /* the last whole blocks, oldest first */
    int32_t held;              /* blocks in window */
    int64_t wait_until;        /* the first block index a decision may end on */
    int32_t refused;           /* the current quiet stretch's refusal is reported */
    int32_t begins;            /* the next row is the first under new offsets */
} sail_rezero_state;

/* Returns SAIL_CHECK_OK, or SAIL_CHECK_NULL / SAIL_CHECK_POLICY.  policy NULL: SAIL_REZERO_POLICY_DEFAULT. */
enum sail_check sail_rezero_init(sail_rezero_state *state, const sail_calibration *cal, const sail_rezero_policy *policy);
/* One row in order: its time [s], its angles [rad], the estimate made with the calibration's offsets (corrected in
 * place: F - F(o + D)), and its contact (SAIL_CONTACT_*).  Returns the decision the row's block ended with
 * (SAIL_REZERO_NONE mostly), described in *event (may be NULL); *begins (may be NULL) is 1 on the first row under
 * new offsets.  A decision is made when a row of the next block arrives: the row that ends a block starts the
 * next one. */
int sail_rezero_step(sail_rezero_state *state, double t, sail_real theta1, sail_real theta2, sail_force *force,
                     int32_t contact, sail_rezero_event *event, int32_t *begins);

#ifdef __cplusplus
}
#endif

#endif /* SAIL_H */
