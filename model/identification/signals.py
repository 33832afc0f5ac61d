"""From a measured log to regression samples: uniform time, zero-phase low-pass, derivatives, decimation.

The steps of :func:`prepare_samples`, each a rule stated here and reported in :class:`Preprocessing`:

1. **Sampling.** The rate is the median of the time steps. When the steps vary by more than
   :data:`JITTER_TOL` of it (a logger's jitter), every column is moved onto the uniform grid
   ``t_0 + k / rate`` by a cubic spline through the samples (``scipy.interpolate.CubicSpline``).
2. **Cut-off.** Unless given, it is read from the spectrum of the joint positions: per joint the Welch
   power spectrum (Hann window, segments of up to :data:`WELCH_SECONDS` s, the linear trend removed), its
   noise floor the median of the spectrum over the upper half of the band (a smooth trajectory puts
   nothing there), and the joint's band edge the highest frequency at which the spectrum stands
   :data:`SNR_FACTOR` (20 dB) above that floor: above it the positions are noise, so their derivatives are
   too. The cut-off is the largest band edge over the joints, but at most :data:`BAND_RATIO` times the
   widest motion band (the frequency below which :data:`SIGNAL_POWER` of a joint's position power lies:
   the rigid-body model explains the motion, not the elastic modes or a controller's corrections above
   it), kept within ``[MIN_CUTOFF_RATIO x rate ... MAX_CUTOFF_RATIO x rate]``.
3. **Filtering.** Positions, given velocities and torques pass the same zero-phase filter:
   a Butterworth low-pass of order :data:`FILTER_ORDER` run forward and backward
   (``scipy.signal.sosfiltfilt``: no phase lag, magnitude squared), each end padded by an odd extension of
   :data:`PAD_PERIODS` periods of the cut-off. The regression applies the same
   filter to every column of the regressor before it is decimated (*parallel filtering*, Gautier 1997):
   ``F(tau) = F(Y) pi`` holds exactly for a linear filter ``F``, so the filter's own gain and the
   smoothing of the Coulomb friction's step at each velocity reversal are the same on both sides.
4. **Derivatives.** Velocities (when the log has none) and accelerations by fourth-order central
   differences of the filtered signals (second order at the two samples of each end).
5. **Trimming and decimation.** :data:`TRIM_PERIODS` periods of the cut-off are dropped at each end
   (the filter's start-up; at most :data:`MAX_TRIM_FRACTION` of the log), then every d-th sample is kept
   with ``d = floor(rate / (DECIMATION_RATIO x cut-off))`` (at least 1): the filtered signals have no
   content above the cut-off, so nothing is lost, and the fewer, less correlated samples give honest
   standard deviations. :attr:`Samples.keep` lists the samples kept; the others stay for the regressor's
   filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.interpolate
import scipy.signal

from ..errors import InputError

__all__ = [
    "DECIMATION_RATIO",
    "FILTER_ORDER",
    "JITTER_TOL",
    "MAX_CUTOFF_RATIO",
    "BAND_RATIO",
    "MIN_CUTOFF_RATIO",
    "SIGNAL_POWER",
    "SNR_FACTOR",
    "LowPass",
    "Preprocessing",
    "Samples",
    "cutoff_from_spectrum",
    "derivative",
    "lowpass",
    "prepare_samples",
]

Array = npt.NDArray[np.float64]

#: Relative spread of the time steps above which the log is resampled onto a uniform grid.
JITTER_TOL = 1e-3
#: Longest Welch segment, s (a resolution of 1/8 Hz, finer than an excitation's harmonics).
WELCH_SECONDS = 8.0
#: How far above the noise floor a joint's spectrum must stand to count as signal (power ratio, 20 dB).
SNR_FACTOR = 100.0
#: The motion's band: the frequency below which this share of a joint's position power (above its floor) lies ...
SIGNAL_POWER = 0.999
#: ... and the cut-off is at most this many times the widest joint's band (the rest is what a rigid model does not
#: explain: joint elasticity, a controller's corrections; the filter's gain is then 1 - 4e-14 over the band).
BAND_RATIO = 50.0
#: The cut-off's bounds as fractions of the sampling rate.
MIN_CUTOFF_RATIO = 0.002
MAX_CUTOFF_RATIO = 0.4
#: Butterworth order (doubled by the forward-backward pass).
FILTER_ORDER = 4
#: Periods of the cut-off by which the filter pads each end of a signal (an odd extension).
PAD_PERIODS = 10.0
#: Periods of the cut-off trimmed at each end of the log, and the most that may be trimmed.
TRIM_PERIODS = 10.0
MAX_TRIM_FRACTION = 0.05
#: The decimated rate is at least this many times the cut-off.
DECIMATION_RATIO = 2.5


@dataclass(frozen=True)
class LowPass:
    """A zero-phase Butterworth low-pass (:func:`lowpass`): cut-off, sampling rate and order."""

    cutoff_hz: float
    rate_hz: float
    order: int = FILTER_ORDER

    def __call__(self, x: npt.ArrayLike) -> Array:
        """``x`` (N, ...) filtered along axis 0."""
        return lowpass(x, self.rate_hz, self.cutoff_hz, self.order)


@dataclass(frozen=True, eq=False)
class Samples:
    """Joint-space samples for the regression (SI units).

    Attributes
    ----------
    t
        (N,) times, s.
    q, qd, qdd, tau
        (N, n) positions, velocities, accelerations and joint torques.
    keep
        Indices of the samples regressed (None: all); the others are there for ``lowpass``.
    lowpass
        The filter the torques went through, which the regressor's columns go through too (None: exact
        samples, nothing filtered).
    """

    t: Array
    q: Array
    qd: Array
    qdd: Array
    tau: Array
    keep: Array | None = None
    lowpass: LowPass | None = None

    def __len__(self) -> int:
        return int(self.t.size if self.keep is None else self.keep.size)

    def kept(self) -> "Samples":
        """The regressed samples only, unfiltered from here on (``keep`` and ``lowpass`` None)."""
        rows = slice(None) if self.keep is None else self.keep
        return Samples(self.t[rows], self.q[rows], self.qd[rows], self.qdd[rows], self.tau[rows])

    def select(self, rows: npt.ArrayLike) -> "Samples":
        """Rows ``rows`` (indices or a boolean mask) of :meth:`kept`."""
        k = self.kept()
        return Samples(k.t[rows], k.q[rows], k.qd[rows], k.qdd[rows], k.tau[rows])


@dataclass(frozen=True)
class Preprocessing:
    """What :func:`prepare_samples` did, for the console and ``identification.json``.

    Attributes
    ----------
    rate_hz
        The log's sampling rate (median step).
    jitter
        Largest deviation of a time step from the median, relative to it.
    resampled
        True when the log was moved onto a uniform grid.
    cutoff_hz, cutoff_source
        The low-pass cut-off and ``"spectrum"`` or ``"given"``.
    band_edges_hz
        Per joint, the band edge read from its spectrum (None for a joint whose spectrum never rises
        above its floor: it barely moves).
    differentiated
        ``"qd, qdd"`` or ``"qdd"``: what was computed by differentiation.
    trimmed_s
        Time dropped at each end, s.
    decimation
        Every how many samples one was kept.
    samples_in, samples_out
        Rows of the log, and samples after trimming and decimation.
    """

    rate_hz: float
    jitter: float
    resampled: bool
    cutoff_hz: float
    cutoff_source: str
    band_edges_hz: tuple[float | None, ...]
    differentiated: str
    trimmed_s: float
    decimation: int
    samples_in: int
    samples_out: int

    def to_dict(self) -> dict:
        return {
            "rate_hz": self.rate_hz, "jitter": self.jitter, "resampled": self.resampled,
            "cutoff_hz": self.cutoff_hz, "cutoff_source": self.cutoff_source,
            "band_edges_hz": list(self.band_edges_hz), "differentiated": self.differentiated,
            "trimmed_s": self.trimmed_s, "decimation": self.decimation, "samples_in": self.samples_in,
            "samples_out": self.samples_out,
        }


def cutoff_from_spectrum(q: npt.ArrayLike, rate_hz: float) -> tuple[float, tuple[float | None, ...]]:
    """The low-pass cut-off (Hz) of the positions ``q`` (N, n) sampled at ``rate_hz``, and each joint's band edge.

    See the module docstring (step 2) for the rule.
    """
    Q = np.asarray(q, dtype=float)
    N = Q.shape[0]
    nper = int(min(N, 2 ** math.ceil(math.log2(max(WELCH_SECONDS * rate_hz, 16)))))
    f, P = scipy.signal.welch(Q, fs=rate_hz, window="hann", nperseg=nper, detrend="linear", axis=0)
    upper = f >= 0.5 * f[-1]
    edges: list[float | None] = []
    bands: list[float] = []
    for j in range(Q.shape[1]):
        floor = float(np.median(P[upper, j]))
        above = np.flatnonzero(P[:, j] > SNR_FACTOR * floor) if floor > 0 else np.flatnonzero(P[:, j] > 0)
        above = above[above > 0]  # DC is the mean, not motion
        edges.append(float(f[above[-1]]) if above.size else None)
        power = np.cumsum(np.maximum(P[1:, j] - floor, 0.0))
        if power[-1] > 0:
            bands.append(float(f[1 + int(np.searchsorted(power, SIGNAL_POWER * power[-1]))]))
    known = [e for e in edges if e is not None]
    fc = max(known) if known else MIN_CUTOFF_RATIO * rate_hz
    if bands:
        fc = min(fc, BAND_RATIO * max(bands))
    return float(min(max(fc, MIN_CUTOFF_RATIO * rate_hz), MAX_CUTOFF_RATIO * rate_hz)), tuple(edges)


def lowpass(x: npt.ArrayLike, rate_hz: float, cutoff_hz: float, order: int = FILTER_ORDER) -> Array:
    """Zero-phase Butterworth low-pass of ``x`` (N, ...) along axis 0 (``scipy.signal.sosfiltfilt``)."""
    sos = scipy.signal.butter(order, cutoff_hz, btype="low", fs=rate_hz, output="sos")
    X = np.asarray(x, dtype=float)
    # padded (odd extension) by PAD_PERIODS periods of the cut-off, not scipy's default of a few samples, so the
    # filter's start-up has died out before the log begins
    pad = min(X.shape[0] - 1, int(math.ceil(PAD_PERIODS * rate_hz / cutoff_hz)))
    return scipy.signal.sosfiltfilt(sos, X, axis=0, padlen=pad)


def derivative(x: npt.ArrayLike, rate_hz: float) -> Array:
    """Time derivative of ``x`` (N, ...) sampled at ``rate_hz``: fourth-order central differences,
    ``(-x[k+2] + 8 x[k+1] - 8 x[k-1] + x[k-2]) / (12 h)``, second order at the two ends."""
    X = np.asarray(x, dtype=float)
    h = 1.0 / rate_hz
    D = np.gradient(X, h, axis=0, edge_order=2)
    if X.shape[0] >= 5:
        D[2:-2] = (-X[4:] + 8 * X[3:-1] - 8 * X[1:-3] + X[:-4]) / (12 * h)
    return D


def _uniform(t: Array, columns: list[Array], rate: float) -> tuple[Array, list[Array]]:
    steps = int(math.floor((t[-1] - t[0]) * rate + 1e-9))
    tu = t[0] + np.arange(steps + 1) / rate
    return tu, [scipy.interpolate.CubicSpline(t, c, axis=0)(tu) for c in columns]


def prepare_samples(t: npt.ArrayLike, q: npt.ArrayLike, tau: npt.ArrayLike, qd: npt.ArrayLike | None = None, *,
                    cutoff_hz: float | None = None, decimation: int | None = None,
                    filtering: bool = True) -> tuple[Samples, Preprocessing]:
    """Regression samples from a log of positions and torques (and optionally velocities).

    Parameters
    ----------
    t
        (N,) strictly increasing times, s.
    q, tau
        (N, n) joint positions (rad or m) and joint torques (N m or N).
    qd
        (N, n) joint velocities, or None to differentiate the filtered positions.
    cutoff_hz
        Low-pass cut-off, Hz; None: from the spectrum (module docstring, step 2).
    decimation
        Keep every d-th sample; None: the rule of step 5.
    filtering
        False: no filter, no trimming (exact data, e.g. a simulation's derivatives are given).

    Raises
    ------
    InputError
        Fewer samples than a filter and a derivative need, or a cut-off or decimation out of range.
    """
    tt = np.asarray(t, dtype=float)
    Q, TAU = np.asarray(q, dtype=float), np.asarray(tau, dtype=float)
    QD = None if qd is None else np.asarray(qd, dtype=float)
    if tt.size < 20:
        raise InputError(f"identification data: {tt.size} samples: expected at least 20")
    steps = np.diff(tt)
    rate = 1.0 / float(np.median(steps))
    jitter = float(np.max(np.abs(steps * rate - 1.0)))
    resampled = jitter > JITTER_TOL
    if resampled:
        cols = [Q, TAU] + ([] if QD is None else [QD])
        tt, cols = _uniform(tt, cols, rate)
        Q, TAU = cols[0], cols[1]
        QD = None if QD is None else cols[2]
    if cutoff_hz is not None and not (math.isfinite(cutoff_hz) and 0 < cutoff_hz < 0.5 * rate):
        raise InputError(f"cutoff_hz: expected a cut-off between 0 and the Nyquist frequency {0.5 * rate:g} Hz, "
                         f"got {cutoff_hz!r}")
    if decimation is not None and not (isinstance(decimation, int) and decimation >= 1):
        raise InputError(f"decimation: expected a whole number >= 1, got {decimation!r}")
    edges = cutoff_from_spectrum(Q, rate)[1] if filtering else (None,) * Q.shape[1]
    if not filtering:
        fc, source = 0.5 * rate, "none"
    elif cutoff_hz is None:
        fc, source = cutoff_from_spectrum(Q, rate)[0], "spectrum"
    else:
        fc, source = float(cutoff_hz), "given"
    if filtering:
        Q, TAU = lowpass(Q, rate, fc), lowpass(TAU, rate, fc)
        QD = None if QD is None else lowpass(QD, rate, fc)
    differentiated = "qd, qdd" if QD is None else "qdd"
    if QD is None:
        QD = derivative(Q, rate)
    QDD = derivative(QD, rate)
    n_in = tt.size
    trim = min(int(math.ceil(TRIM_PERIODS * rate / fc)), int(MAX_TRIM_FRACTION * n_in)) if filtering else 0
    d = decimation if decimation is not None else max(1, int(math.floor(rate / (DECIMATION_RATIO * fc))))
    keep = np.arange(trim, n_in - trim, d)
    if keep.size < 10:
        raise InputError(f"identification data: {keep.size} samples left after trimming {trim} at each end and "
                         f"keeping every {d}th: expected at least 10 (a longer log, or a smaller --decimation)")
    samples = Samples(tt, Q, QD, QDD, TAU, keep=keep, lowpass=LowPass(fc, rate) if filtering else None)
    info = Preprocessing(rate_hz=rate, jitter=jitter, resampled=resampled, cutoff_hz=fc, cutoff_source=source,
                         band_edges_hz=edges, differentiated=differentiated, trimmed_s=trim / rate, decimation=d,
                         samples_in=n_in, samples_out=int(keep.size))
    return samples, info
