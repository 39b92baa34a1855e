// Detection independent of the candidate library, and where the residual sits (private to gap/):
// noise floor, structure above it, and the description of what is left.
#include "detection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include <fmt/format.h>

#include "spectrum.h"
#include "stats.h"

namespace hexsim::gap::internal {

// High-frequency noise variance per component: mean |e_k − e_{k−1}|² / 6 over close pairs.
double NoiseVariance(const std::vector<double>& t, const std::vector<Vec3>& e) {
  if (e.size() < 3) return 0.0;
  std::vector<double> dts;
  for (size_t k = 1; k < t.size(); ++k) dts.push_back(t[k] - t[k - 1]);
  std::nth_element(dts.begin(), dts.begin() + dts.size() / 2, dts.end());
  const double med = dts[dts.size() / 2];
  double s = 0;
  size_t m = 0;
  for (size_t k = 1; k < e.size(); ++k) {
    if (t[k] - t[k - 1] > 3 * med) continue;
    s += (e[k] - e[k - 1]).squaredNorm();
    ++m;
  }
  return m > 0 ? s / (6.0 * static_cast<double>(m)) : 0.0;
}

// The floor of a replay whose unresolvable part is not white (the dynamics channel: commands
// between log rows): per-component variance of the residual minus its centred moving average over
// window_s, corrected for the average's own share of white noise (1 − 1/m, m samples per window).
double HighPassVariance(const std::vector<double>& t, const std::vector<Vec3>& e, double window_s) {
  const size_t n = e.size();
  if (n < 3) return 0.0;
  size_t a = 0, b = 0;
  Vec3 sum = Vec3::Zero();
  double s = 0, m_sum = 0;
  for (size_t k = 0; k < n; ++k) {
    while (b < n && t[b] <= t[k] + window_s / 2) sum += e[b++];
    while (a < b && t[a] < t[k] - window_s / 2) sum -= e[a++];
    const double m = static_cast<double>(std::max<size_t>(1, b - a));
    s += (e[k] - sum / m).squaredNorm();
    m_sum += m;
  }
  const double m_mean = m_sum / static_cast<double>(n);
  if (!(m_mean > 1.5)) return 0.0;
  return s / (3.0 * static_cast<double>(n)) / (1.0 - 1.0 / m_mean);
}

double MeanSquare(const std::vector<Vec3>& e) {
  double s = 0;
  for (const auto& v : e) s += v.squaredNorm();
  return e.empty() ? 0.0 : s / (3.0 * static_cast<double>(e.size()));
}

namespace {

std::string Quartile(int q) {
  static const char* names[] = {"low", "mid-low", "mid-high", "high"};
  return names[std::clamp(q, 0, 3)];
}

// The residual's RMS per quartile bin of a regime variable v (per sample); false when fewer than 40
// samples carry v. ratio: the highest bin's RMS over the lowest's; hi_q: the highest bin.
bool SplitByQuartile(const std::vector<double>& v, const std::vector<Vec3>& y, RegimeSplit* split, double* ratio, int* hi_q) {
  std::vector<double> sorted;
  for (double x : v) {
    if (std::isfinite(x)) sorted.push_back(x);
  }
  if (sorted.size() < 40) return false;
  std::sort(sorted.begin(), sorted.end());
  double edges[3];
  for (int q = 0; q < 3; ++q) edges[q] = sorted[(q + 1) * sorted.size() / 4];
  double s[4] = {0, 0, 0, 0}, m[4] = {0, 0, 0, 0};
  for (size_t k = 0; k < y.size(); ++k) {
    if (!std::isfinite(v[k])) continue;
    int q = 0;
    while (q < 3 && v[k] > edges[q]) ++q;
    s[q] += y[k].squaredNorm() / 3;
    m[q] += 1;
  }
  double lo = 1e300, hi = 0;
  *hi_q = 0;
  for (int q = 0; q < 4; ++q) {
    const double rms = m[q] > 0 ? std::sqrt(s[q] / m[q]) : 0.0;
    split->bins.push_back({Quartile(q), rms, m[q]});
    if (m[q] > 0) {
      lo = std::min(lo, rms);
      if (rms > hi) {
        hi = rms;
        *hi_q = q;
      }
    }
  }
  split->edges = {edges[0], edges[1], edges[2]};
  *ratio = lo > 0 ? hi / lo : 0;
  return true;
}

}  // namespace

// Where: phase, regime bins and frequency band of the residual.
Where Locate(const ChannelData& ch, const std::vector<Vec3>& y, const logs::FlightLog& log,
             const std::vector<std::string>& phases) {
  Where w;
  w.present = true;
  const size_t n = y.size();
  const double total_ms = MeanSquare(y);
  // Phase.
  std::map<std::string, std::pair<double, double>> by_phase;
  for (size_t k = 0; k < n; ++k) {
    auto& a = by_phase[phases[ch.row[k]]];
    a.first += y[k].squaredNorm() / 3;
    a.second += 1;
  }
  std::string worst_phase;
  double worst = -1;
  for (const auto& [ph, a] : by_phase) {
    const double rms = std::sqrt(a.first / a.second);
    w.rms_by_phase[ph] = rms;
    if (a.second >= 0.03 * static_cast<double>(n) && rms > worst) {
      worst = rms;
      worst_phase = ph;
    }
  }
  w.phase_concentrated = worst_phase;
  // Regimes: quartile bins of current, throttle, speed, tilt.
  auto column_at_rows = [&](const std::string& name, auto fn) {
    std::vector<double> v(n, std::nan(""));
    for (size_t k = 0; k < n; ++k) v[k] = fn(static_cast<size_t>(ch.row[k]));
    (void)name;
    return v;
  };
  std::vector<std::pair<std::string, std::vector<double>>> regs;
  if (log.Has("current_A")) {
    const auto& c = log.Column("current_A");
    regs.emplace_back("current", column_at_rows("current_A", [&](size_t i) { return c[i]; }));
  }
  if (log.Has("control_u")) {
    const auto& c = log.Column("control_u");
    regs.emplace_back("throttle", column_at_rows("control_u", [&](size_t i) { return c[i]; }));
  }
  if (log.Has("vel_N_mps") && log.Has("vel_E_mps")) {
    const auto& vn = log.Column("vel_N_mps");
    const auto& ve = log.Column("vel_E_mps");
    regs.emplace_back("speed", column_at_rows("speed", [&](size_t i) { return std::hypot(vn[i], ve[i]); }));
  }
  if (log.Has("q_w")) {
    const auto& qw = log.Column("q_w");
    const auto& qx = log.Column("q_x");
    const auto& qy = log.Column("q_y");
    const auto& qz = log.Column("q_z");
    regs.emplace_back("tilt", column_at_rows("tilt", [&](size_t i) {
                        // cos(tilt) = R_NB(2,2) = 1 − 2(qx² + qy²)
                        return std::acos(std::clamp(1 - 2 * (qx[i] * qx[i] + qy[i] * qy[i]), -1.0, 1.0)) * 57.29577951308232 +
                               0 * qw[i] * qz[i];
                      }));
  }
  std::string conc;
  double best_ratio = 0;
  for (const auto& [name, v] : regs) {
    double ratio = 0;
    int hi_q = 0;
    RegimeSplit split;
    if (!SplitByQuartile(v, y, &split, &ratio, &hi_q)) continue;
    w.regime[name] = split;
    if (ratio > best_ratio) {
      best_ratio = ratio;
      conc = Quartile(hi_q) + " " + name;
    }
  }
  w.regime_concentrated = best_ratio > 1.2 ? conc : "uniform";
  // Band: moving averages split low (< ~0.1 Hz), mid, high (> ~1 Hz) parts.
  auto moving_avg = [&](double window_s) {
    std::vector<Vec3> out(n, Vec3::Zero());
    size_t a = 0, b = 0;
    Vec3 sum = Vec3::Zero();
    for (size_t k = 0; k < n; ++k) {
      while (b < n && ch.t[b] <= ch.t[k] + window_s / 2) sum += y[b++];
      while (a < b && ch.t[a] < ch.t[k] - window_s / 2) sum -= y[a++];
      out[k] = sum / static_cast<double>(std::max<size_t>(1, b - a));
    }
    return out;
  };
  const auto slow = moving_avg(5.0);
  const auto mid = moving_avg(0.5);
  double e_lo = 0, e_mid = 0, e_hi = 0;
  for (size_t k = 0; k < n; ++k) {
    e_lo += slow[k].squaredNorm();
    e_mid += (mid[k] - slow[k]).squaredNorm();
    e_hi += (y[k] - mid[k]).squaredNorm();
  }
  const double e_sum = e_lo + e_mid + e_hi;
  w.band_below_0p2Hz = e_sum > 0 ? e_lo / e_sum : 0.0;
  w.band_0p2_to_2Hz = e_sum > 0 ? e_mid / e_sum : 0.0;
  w.band_above_2Hz = e_sum > 0 ? e_hi / e_sum : 0.0;
  std::string dom = "below_0.2Hz";
  if (e_mid >= e_lo && e_mid >= e_hi) dom = "0.2_to_2Hz";
  if (e_hi >= e_lo && e_hi >= e_mid) dom = "above_2Hz";
  w.band_concentrated = dom;
  w.rms = std::sqrt(total_ms);
  return w;
}


namespace {

// Periodogram of the residual (axes summed) at Fourier frequencies 1..m/2 of the residual taken every
// ⌊n/4096⌋-th sample (m < 8192 samples), by FFT; returns {f_Hz, power}.
std::pair<std::vector<double>, std::vector<double>> Periodogram(const std::vector<double>& t, const std::vector<Vec3>& r) {
  std::vector<double> fs, ps;
  const size_t n = r.size();
  if (n < 64) return {fs, ps};
  std::vector<double> dts;
  dts.reserve(n);
  for (size_t k = 1; k < n; ++k) dts.push_back(t[k] - t[k - 1]);
  std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2), dts.end());
  const size_t step = std::max<size_t>(1, n / 4096);
  const double dt = dts[dts.size() / 2] * static_cast<double>(step);
  std::vector<Vec3> x;
  for (size_t k = 0; k < n; k += step) x.push_back(r[k]);
  const size_t m = x.size();
  Vec3 mean = Vec3::Zero();
  for (const auto& v : x) mean += v;
  mean /= static_cast<double>(m);
  for (auto& v : x) v -= mean;
  ps = FourierPower(x);
  for (size_t f = 1; f <= ps.size(); ++f) {
    fs.push_back(static_cast<double>(f) / (static_cast<double>(m) * dt));
    ps[f - 1] /= static_cast<double>(m);
  }
  return {fs, ps};
}

}  // namespace

int CountSpikes(const std::vector<Vec3>& r) {
  const size_t n = r.size();
  if (n < 20) return 0;
  int count = 0;
  for (int a = 0; a < 3; ++a) {
    // Departure of each sample from the mean of its neighbours, and its robust spread.
    std::vector<double> e(n, 0.0), abs_e;
    abs_e.reserve(n);
    for (size_t k = 1; k + 1 < n; ++k) {
      e[k] = r[k][a] - 0.5 * (r[k - 1][a] + r[k + 1][a]);
      abs_e.push_back(std::fabs(e[k]));
    }
    std::nth_element(abs_e.begin(), abs_e.begin() + static_cast<std::ptrdiff_t>(abs_e.size() / 2), abs_e.end());
    const double sigma = 1.4826 * abs_e[abs_e.size() / 2];
    if (!(sigma > 0)) continue;
    for (size_t k = 1; k + 1 < n; ++k) {
      // A spike leaves both neighbours (a step leaves one): its own departure is the largest.
      if (std::fabs(e[k]) > kSpikeSigma * sigma && std::fabs(e[k]) >= std::fabs(e[k - 1]) &&
          std::fabs(e[k]) >= std::fabs(e[k + 1])) {
        ++count;
      }
    }
  }
  return count;
}

Structure DetectStructure(const std::vector<double>& t, const std::vector<Vec3>& r, double heldout_sse, double materiality,
                          double flex_p, double flex_gain_ms, double alpha) {
  Structure s;
  const size_t n = r.size();
  if (n < 20) return s;
  s.noise_var = NoiseVariance(t, r);
  const double m = 3.0 * static_cast<double>(n);
  s.power_ratio = s.noise_var > 0 ? heldout_sse / m / s.noise_var : 0.0;
  const double a2 = alpha / 2.0;
  // (1) Library-free regressors.
  s.flex_p = flex_p;
  s.flex_gain_ms = flex_gain_ms;
  if (s.flex_p < a2 && s.flex_gain_ms >= materiality * s.noise_var) s.found = "predictable from the field, current or throttle";
  // (2) A line: the periodogram over its running median of ±kHalf bins (the coloured background).
  // Per bin P/S ~ χ²₆/6 (three axes, two dof each); the median of χ²₆/6 is 0.891. Bonferroni over
  // the bins; material when the line holds ≥ materiality of the noise floor's power.
  {
    const auto [fs, ps] = Periodogram(t, r);
    constexpr size_t kHalf = 10;
    double best = 0;
    size_t best_i = 0;
    std::vector<double> win;
    for (size_t i = 0; i < ps.size(); ++i) {
      win.clear();
      for (size_t j = i > kHalf ? i - kHalf : 0; j < std::min(ps.size(), i + kHalf + 1); ++j) {
        if (j != i) win.push_back(ps[j]);
      }
      if (win.size() < kHalf) continue;
      std::nth_element(win.begin(), win.begin() + static_cast<std::ptrdiff_t>(win.size() / 2), win.end());
      const double bg = win[win.size() / 2] / 0.891;
      const double ratio = bg > 0 ? ps[i] / bg : 0.0;
      if (ratio > best) {
        best = ratio;
        best_i = i;
      }
    }
    if (best > 0) {
      s.line_freq_Hz = fs[best_i];
      s.line_p = std::min(1.0, ChiSquareSf(6.0 * best, 6.0) * static_cast<double>(ps.size()));
      // Line power as a mean square per component: 2·P/(3·m_dec) of the decimated series.
      const double m_dec = 2.0 * static_cast<double>(ps.size());
      s.line_share = s.noise_var > 0 ? 2.0 * ps[best_i] / (3.0 * m_dec) / s.noise_var : 0.0;
      if (s.line_p < a2 && s.line_share >= materiality) {
        s.found += std::string(s.found.empty() ? "" : "; ") + fmt::format("a line at {:.2f} Hz", s.line_freq_Hz);
      }
    }
  }
  s.spikes = CountSpikes(r);
  if (s.spikes >= kMinSpikes) {
    s.found += std::string(s.found.empty() ? "" : "; ") +
               fmt::format("{} isolated spikes beyond {:.0f} robust sigma (an intermittent disturbance)", s.spikes, kSpikeSigma);
  }
  s.present = !s.found.empty();
  s.p_value = std::min(1.0, 2.0 * std::min(s.flex_p, s.line_p));
  // Spikes: a Gaussian floor's chance of one departure beyond kSpikeSigma over the 3n values.
  if (s.spikes >= kMinSpikes) s.p_value = std::min(s.p_value, std::min(1.0, 6.0 * static_cast<double>(n) * NormalSf(kSpikeSigma)));
  constexpr int kLjungBoxLags = 20;
  double p_lb = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    x.reserve(r.size());
    for (const auto& v : r) x.push_back(v[axis]);
    p_lb = std::min(p_lb, 3.0 * LjungBoxP(x, kLjungBoxLags));
  }
  s.whiteness_p = std::min(1.0, p_lb);
  return s;
}

ResidualLeft DescribeLeft(const std::vector<double>& t, const std::vector<Vec3>& after, double share_left,
                          const Where& where_after) {
  ResidualLeft j;
  j.present = true;
  j.share = std::clamp(share_left, 0.0, 1.0);
  const size_t n = after.size();
  // Dominant frequency: periodogram on the sample index (median spacing), every ⌊n/2048⌋-th sample
  // (m < 4096), summed over the three axes, by FFT.
  double f_dom = 0;
  if (n >= 32) {
    std::vector<double> dts;
    dts.reserve(n);
    for (size_t k = 1; k < n; ++k) dts.push_back(t[k] - t[k - 1]);
    std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2), dts.end());
    const size_t step = std::max<size_t>(1, n / 2048);
    const double dt = dts[dts.size() / 2] * static_cast<double>(step);
    std::vector<Vec3> x;
    x.reserve(n / step + 1);
    for (size_t k = 0; k < n; k += step) x.push_back(after[k]);
    const size_t m = x.size();
    Vec3 mean = Vec3::Zero();
    for (const auto& v : x) mean += v;
    mean /= static_cast<double>(m);
    for (auto& v : x) v -= mean;
    const std::vector<double> power = FourierPower(x);
    double best = -1;
    for (size_t f = 1; f <= power.size(); ++f) {
      if (power[f - 1] > best) {
        best = power[f - 1];
        f_dom = static_cast<double>(f) / (static_cast<double>(m) * dt);
      }
    }
  }
  j.dominant_freq_Hz = f_dom;
  // Trend: share of the residual mean square a straight line in time explains (per axis).
  double trend_ss = 0, total_ss = 0;
  if (n >= 3) {
    const double tm = std::accumulate(t.begin(), t.end(), 0.0) / static_cast<double>(n);
    double stt = 0;
    for (double v : t) stt += (v - tm) * (v - tm);
    Vec3 ym = Vec3::Zero(), sty = Vec3::Zero();
    for (const auto& v : after) ym += v;
    ym /= static_cast<double>(n);
    for (size_t k = 0; k < n; ++k) {
      sty += (t[k] - tm) * (after[k] - ym);
      total_ss += after[k].squaredNorm();
    }
    if (stt > 0) trend_ss = sty.squaredNorm() / stt;
  }
  j.trend = total_ss > 0 ? trend_ss / total_ss : 0.0;
  j.spikes = CountSpikes(after);
  std::string conc = where_after.phase_concentrated;
  const std::string& regime = where_after.regime_concentrated;
  if (!regime.empty() && regime != "uniform") conc += (conc.empty() ? "" : ", ") + regime;
  j.concentrated = conc;
  return j;
}

}  // namespace hexsim::gap::internal
