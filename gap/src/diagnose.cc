// Where / which / how much: block statistics, blocked CV, block bootstrap, intervals, verdicts.
#include "hexsim/gap/diagnose.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <fmt/format.h>

#include "channels.h"
#include "hexsim/common/rng.h"
#include "stats.h"

namespace hexsim::gap {

using internal::Candidate;
using internal::ChannelData;
using internal::Vec3;

namespace {

// Every effect of the library has a candidate now; per-motor current hard iron does not.
const char* const kEffectsNotBuilt[] = {"per_motor_current_hard_iron"};

// Per-block normal equations of one candidate: A = Σ XᵀX, g = Σ Xᵀy, s = Σ yᵀy, n = 3·samples.
struct Block {
  Eigen::MatrixXd A;
  Eigen::VectorXd g;
  double s = 0, n = 0;
};

struct Fit {
  Eigen::VectorXd beta;
  double sse = 0, n = 0;
  bool ok = false;
};

Fit Solve(const std::vector<Block>& blocks, const std::vector<double>& w, int p) {
  Fit f;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  double s = 0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (w[b] == 0) continue;
    A += w[b] * blocks[b].A;
    g += w[b] * blocks[b].g;
    s += w[b] * blocks[b].s;
    f.n += w[b] * blocks[b].n;
  }
  const double tr = A.trace();
  if (!(tr > 0)) return f;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(A + Eigen::MatrixXd::Identity(p, p) * (1e-12 * tr / p));
  if (ldlt.info() != Eigen::Success) return f;
  f.beta = ldlt.solve(g);
  f.sse = std::max(0.0, s - f.beta.dot(g));
  f.ok = f.beta.allFinite();
  return f;
}

double HeldOutSse(const Block& b, const Eigen::VectorXd& beta) {
  return std::max(0.0, b.s - 2 * beta.dot(b.g) + beta.dot(b.A * beta));
}

// Block index of each sample: G contiguous blocks of (nearly) equal sample count.
std::vector<int> BlockIndex(size_t n, int G) {
  std::vector<int> idx(n);
  for (size_t k = 0; k < n; ++k) idx[k] = static_cast<int>(k * static_cast<size_t>(G) / n);
  return idx;
}

// Stacks several candidates' regressors side by side.
Candidate Join(const Candidate& a, const Candidate& b) {
  Candidate j = a;
  j.effect = a.effect + "+" + b.effect;
  j.names.insert(j.names.end(), b.names.begin(), b.names.end());
  j.scale.insert(j.scale.end(), b.scale.begin(), b.scale.end());
  for (size_t k = 0; k < j.X.size(); ++k) {
    internal::Mat3X x(3, a.p() + b.p());
    x << a.X[k], b.X[k];
    j.X[k] = x;
  }
  return j;
}

struct Evaluated {
  const Candidate* cand = nullptr;
  std::vector<Block> blocks;
  Fit full;
  double cv_sse = 0;
  double p_value = 1;
  double bic = 0;
  double wald_p = 1;    // cluster-robust Wald test of all parameters (Hotelling T², F(p, G − p))
  Eigen::MatrixXd cov;  // cluster-robust covariance of beta
};

// Cluster-robust Wald test that the parameters `idx` are zero: Hotelling's T² over G blocks,
// F = T²·(G − q)/(q·(G − 1)) ~ F(q, G − q). Blocks are long against the residual's correlation
// time, so the test stays valid when the residual is coloured (e.g. the unresolvable part of the
// configured wiring field between two current samples), unlike an F test that assumes white noise.
double WaldP(const Eigen::VectorXd& beta, const Eigen::MatrixXd& cov, const std::vector<int>& idx, int G) {
  const int q = static_cast<int>(idx.size());
  if (q == 0) return 1.0;
  Eigen::VectorXd b(q);
  Eigen::MatrixXd V(q, q);
  for (int i = 0; i < q; ++i) {
    b[i] = beta[idx[i]];
    for (int j = 0; j < q; ++j) V(i, j) = cov(idx[i], idx[j]);
  }
  const double tr = V.trace();
  if (!(tr > 0) || !b.allFinite()) return 1.0;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(V + Eigen::MatrixXd::Identity(q, q) * (1e-9 * tr / q));
  if (ldlt.info() != Eigen::Success) return 1.0;
  const double t2 = b.dot(ldlt.solve(b));
  if (G - q < 1) return internal::ChiSquareSf(t2, q);
  const double f = t2 * static_cast<double>(G - q) / (static_cast<double>(q) * (G - 1));
  return internal::FSf(f, q, G - q);
}

std::vector<int> Range(int a, int b) {
  std::vector<int> v;
  for (int i = a; i < b; ++i) v.push_back(i);
  return v;
}

class Analyzer {
 public:
  Analyzer(const ChannelData& ch, const DiagnoseOptions& o) : ch_(ch), o_(o) {
    n_ = ch.t.size();
    G_ = std::max(4, std::min(o.blocks, static_cast<int>(n_ / 50)));
    block_ = BlockIndex(n_, G_);
    // Residual, with the nuisance intercept removed when the configured sensor has a bias.
    y_ = ch.y;
    if (ch.bias_nuisance) {
      mean_y_ = Vec3::Zero();
      for (const auto& v : y_) mean_y_ += v;
      mean_y_ /= static_cast<double>(n_);
      for (auto& v : y_) v -= mean_y_;
    }
    base_.assign(G_, 0.0);
    base_n_.assign(G_, 0.0);
    for (size_t k = 0; k < n_; ++k) {
      base_[block_[k]] += y_[k].squaredNorm();
      base_n_[block_[k]] += 3;
    }
    total_base_ = std::accumulate(base_.begin(), base_.end(), 0.0);
    total_n_ = 3.0 * static_cast<double>(n_);
  }

  int G() const { return G_; }
  double base_sse() const { return total_base_; }
  double total_n() const { return total_n_; }
  const std::vector<double>& base_blocks() const { return base_; }
  const std::vector<double>& base_n() const { return base_n_; }
  const std::vector<Vec3>& y() const { return y_; }

  Evaluated Evaluate(const Candidate& c) const {
    Evaluated e;
    e.cand = &c;
    const int p = c.p();
    e.blocks.assign(G_, Block{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), 0, 0});
    std::vector<Eigen::VectorXd> colmean;
    internal::Mat3X mean_x = internal::Mat3X::Zero(3, p);
    if (ch_.bias_nuisance) {
      for (const auto& x : c.X) mean_x += x;
      mean_x /= static_cast<double>(n_);
    }
    for (size_t k = 0; k < n_; ++k) {
      const internal::Mat3X x = c.X[k] - mean_x;
      Block& b = e.blocks[block_[k]];
      b.A.noalias() += x.transpose() * x;
      b.g.noalias() += x.transpose() * y_[k];
      b.s += y_[k].squaredNorm();
      b.n += 3;
    }
    std::vector<double> w(G_, 1.0);
    e.full = Solve(e.blocks, w, p);
    if (!e.full.ok) return e;
    // Blocked CV: G/2 folds of two adjacent blocks each.
    e.cv_sse = 0;
    for (int f = 0; f < G_; f += 2) {
      std::vector<double> wf(G_, 1.0);
      wf[f] = 0;
      if (f + 1 < G_) wf[f + 1] = 0;
      const Fit fit = Solve(e.blocks, wf, p);
      for (int b = f; b < std::min(G_, f + 2); ++b) {
        e.cv_sse += fit.ok ? HeldOutSse(e.blocks[b], fit.beta) : e.blocks[b].s;
      }
    }
    // F test against no effect (large-sample chi-square form).
    const double dof = total_n_ - p - (ch_.bias_nuisance ? 3 : 0);
    const double sigma2 = e.full.sse / std::max(1.0, dof);
    const double chi2 = sigma2 > 0 ? (total_base_ - e.full.sse) / sigma2 : 0.0;
    e.p_value = internal::ChiSquareSf(chi2, p);
    e.bic = total_n_ * std::log(std::max(e.full.sse, 1e-300) / total_n_) + p * std::log(total_n_);
    // Cluster-robust covariance over blocks: A⁻¹ (Σ u_b u_bᵀ) A⁻¹ · G/(G−1), u_b = g_b − A_b β.
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(p, p);
    for (const Block& b : e.blocks) {
      A += b.A;
      const Eigen::VectorXd u = b.g - b.A * e.full.beta;
      meat += u * u.transpose();
    }
    const Eigen::MatrixXd Ainv = A.inverse();
    e.cov = Ainv * meat * Ainv * (static_cast<double>(G_) / (G_ - 1));
    e.wald_p = WaldP(e.full.beta, e.cov, Range(0, p), G_);
    return e;
  }

  // Residual after subtracting the full-data fit of c.
  std::vector<Vec3> After(const Evaluated& e) const {
    std::vector<Vec3> r(y_);
    internal::Mat3X mean_x = internal::Mat3X::Zero(3, e.cand->p());
    if (ch_.bias_nuisance) {
      for (const auto& x : e.cand->X) mean_x += x;
      mean_x /= static_cast<double>(n_);
    }
    for (size_t k = 0; k < n_; ++k) r[k] -= (e.cand->X[k] - mean_x) * e.full.beta;
    return r;
  }

  const std::vector<int>& block() const { return block_; }

 private:
  const ChannelData& ch_;
  const DiagnoseOptions& o_;
  size_t n_ = 0;
  int G_ = 0;
  std::vector<int> block_;
  std::vector<Vec3> y_;
  Vec3 mean_y_ = Vec3::Zero();
  std::vector<double> base_, base_n_;
  double total_base_ = 0, total_n_ = 0;
};

double Shrink(double after_sse, double before_sse) {
  if (!(before_sse > 0)) return 0.0;
  return 1.0 - std::sqrt(std::max(0.0, after_sse) / before_sse);
}

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

// Which manoeuvre separates two collinear candidates.
std::string SeparatingManoeuvre(const std::string& a, const std::string& b) {
  auto is = [&](const char* x, const char* y) { return (a == x && b == y) || (a == y && b == x); };
  if (is("current_hard_iron", "throttle_hard_iron"))
    return "hold one throttle while the current changes (a long hover as the battery sags, or a payload change): "
           "current-driven field follows the current, throttle-driven does not";
  if (is("current_hard_iron", "current_soft_iron"))
    return "a slow 360 deg yaw turn at constant high current: a soft-iron change varies with heading, a hard iron does not";
  if (is("hard_iron_offset", "local_anomaly"))
    return "yaw turns and large pitch/roll, or the same pattern at another site: an anomaly is fixed in NED, a hard iron in the body";
  if (is("battery_sag", "thrust_scale"))
    return "climbs and descents over a wide throttle range, or a long hover as the battery drains: a voltage sag grows "
           "with current x dT/dV (faster than the thrust), a k_T or mass error stays proportional to the thrust";
  if (is("wind", "rotor_drag"))
    return "hover facing several headings and fly the same legs both ways: wind drag is fixed in NED, rotor drag "
           "follows the air speed and the rotor speed";
  if (is("latency", "current_lag"))
    return "fast yaw turns at constant throttle (latency shows) against throttle steps at constant attitude (current lag shows)";
  if (is("misalignment", "local_anomaly") || is("misalignment", "hard_iron_offset") || is("misalignment", "scale_error"))
    return "rotate through all attitudes (full yaw turns and large pitch/roll)";
  return "a manoeuvre that varies the regressor of '" + a + "' while holding that of '" + b + "' fixed";
}

std::string Quartile(int q) {
  static const char* names[] = {"low", "mid-low", "mid-high", "high"};
  return names[std::clamp(q, 0, 3)];
}

// Where: phase, regime bins and frequency band of the residual.
nlohmann::json Where(const ChannelData& ch, const std::vector<Vec3>& y, const logs::FlightLog& log,
                     const std::vector<std::string>& phases) {
  nlohmann::json w;
  const size_t n = y.size();
  const double total_ms = MeanSquare(y);
  // Phase.
  std::map<std::string, std::pair<double, double>> by_phase;
  for (size_t k = 0; k < n; ++k) {
    auto& a = by_phase[phases[ch.row[k]]];
    a.first += y[k].squaredNorm() / 3;
    a.second += 1;
  }
  nlohmann::json rms_phase = nlohmann::json::object();
  std::string worst_phase;
  double worst = -1;
  for (const auto& [ph, a] : by_phase) {
    const double rms = std::sqrt(a.first / a.second);
    rms_phase[ph] = rms;
    if (a.second >= 0.03 * static_cast<double>(n) && rms > worst) {
      worst = rms;
      worst_phase = ph;
    }
  }
  w["phase"] = {{"rms_by_phase", rms_phase}, {"concentrated", worst_phase}};
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
  nlohmann::json regime = nlohmann::json::object();
  std::string conc;
  double best_ratio = 0;
  for (const auto& [name, v] : regs) {
    std::vector<double> sorted;
    for (double x : v) {
      if (std::isfinite(x)) sorted.push_back(x);
    }
    if (sorted.size() < 40) continue;
    std::sort(sorted.begin(), sorted.end());
    double edges[3];
    for (int q = 0; q < 3; ++q) edges[q] = sorted[(q + 1) * sorted.size() / 4];
    double s[4] = {0, 0, 0, 0}, m[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < n; ++k) {
      if (!std::isfinite(v[k])) continue;
      int q = 0;
      while (q < 3 && v[k] > edges[q]) ++q;
      s[q] += y[k].squaredNorm() / 3;
      m[q] += 1;
    }
    nlohmann::json bins = nlohmann::json::array();
    double lo = 1e300, hi = 0;
    int hi_q = 0;
    for (int q = 0; q < 4; ++q) {
      const double rms = m[q] > 0 ? std::sqrt(s[q] / m[q]) : 0.0;
      bins.push_back({{"bin", Quartile(q)}, {"rms", rms}, {"samples", m[q]}});
      if (m[q] > 0) {
        lo = std::min(lo, rms);
        if (rms > hi) {
          hi = rms;
          hi_q = q;
        }
      }
    }
    regime[name] = {{"edges", {edges[0], edges[1], edges[2]}}, {"bins", bins}};
    const double ratio = lo > 0 ? hi / lo : 0;
    if (ratio > best_ratio) {
      best_ratio = ratio;
      conc = Quartile(hi_q) + " " + name;
    }
  }
  regime["concentrated"] = best_ratio > 1.2 ? conc : "uniform";
  w["regime"] = regime;
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
  nlohmann::json band = {{"below_0.2Hz", e_sum > 0 ? e_lo / e_sum : 0.0},
                         {"0.2_to_2Hz", e_sum > 0 ? e_mid / e_sum : 0.0},
                         {"above_2Hz", e_sum > 0 ? e_hi / e_sum : 0.0}};
  std::string dom = "below_0.2Hz";
  if (e_mid >= e_lo && e_mid >= e_hi) dom = "0.2_to_2Hz";
  if (e_hi >= e_lo && e_hi >= e_mid) dom = "above_2Hz";
  band["concentrated"] = dom;
  w["band"] = band;
  w["rms"] = std::sqrt(total_ms);
  return w;
}

// Fills the reported parameters, intervals and magnitude of a candidate fit.
void Describe(const Evaluated& e, const std::vector<double>& grid_boot, CandidateResult* r) {
  const Candidate& c = *e.cand;
  const double t975 = internal::StudentT975(static_cast<double>(e.blocks.size() - 1));
  const int p = c.p();
  for (int j = 0; j < p; ++j) {
    const double v = e.full.beta[j] * c.scale[j];
    const double sd = std::sqrt(std::max(0.0, e.cov(j, j))) * std::fabs(c.scale[j]);
    r->params[c.names[j]] = v;
    r->ci95[c.names[j]] = {v - t975 * sd, v + t975 * sd};
  }
  if (!c.grid_name.empty()) {
    r->params[c.grid_name] = c.grid_value;
    std::vector<double> g = grid_boot;
    std::sort(g.begin(), g.end());
    double lo = c.grid_value, hi = c.grid_value;
    if (!g.empty()) {
      lo = std::min(lo, g[static_cast<size_t>(0.025 * (g.size() - 1))]);
      hi = std::max(hi, g[static_cast<size_t>(std::ceil(0.975 * (g.size() - 1)))]);
    }
    r->ci95[c.grid_name] = {lo, hi};
    r->magnitude = c.grid_value;
    r->magnitude_ci95[0] = lo;
    r->magnitude_ci95[1] = hi;
    r->magnitude_unit = "s";
    return;
  }
  r->magnitude_unit = c.magnitude_unit;
  const int pm = c.magnitude_params > 0 ? c.magnitude_params : p;
  Eigen::VectorXd v(pm);
  for (int j = 0; j < pm; ++j) v[j] = e.full.beta[j] * c.scale[j];
  Eigen::MatrixXd S = Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(c.scale.data(), pm)).asDiagonal();
  const Eigen::MatrixXd cov = S * e.cov.topLeftCorner(pm, pm) * S;
  if (pm == 1) {
    r->magnitude = v[0];
    const double sd = std::sqrt(std::max(0.0, cov(0, 0)));
    r->magnitude_ci95[0] = v[0] - t975 * sd;
    r->magnitude_ci95[1] = v[0] + t975 * sd;
    return;
  }
  const double mag = v.norm();
  const Eigen::VectorXd grad = mag > 0 ? Eigen::VectorXd(v / mag) : Eigen::VectorXd::Zero(pm);
  // |v| is biased up by noise; the delta-method interval is widened by the trace term.
  const double var = grad.dot(cov * grad);
  const double sd = std::sqrt(std::max(0.0, var));
  r->magnitude = mag;
  r->magnitude_ci95[0] = std::max(0.0, mag - t975 * sd);
  r->magnitude_ci95[1] = mag + t975 * sd;
}

ChannelResult Analyze(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                      const DiagnoseOptions& o, RngStream* rng) {
  ChannelResult res;
  res.channel = ch.name;
  res.unit = ch.unit;
  res.samples = static_cast<int>(ch.t.size());
  res.not_available = ch.not_available;
  Analyzer an(ch, o);
  res.rms_before = std::sqrt(MeanSquare(ch.y));
  res.t_s = ch.t;
  res.residual_before = an.y();
  // Channels whose effects are phase-confined and low-frequency (dynamics) take their floor from
  // the residual above ~4 Hz, which holds the replay's own unresolvable part.
  constexpr double kFloorWindow_s = 0.25;
  auto floor_variance = [&](const std::vector<Vec3>& e) {
    return ch.explain_above_noise ? HighPassVariance(ch.t, e, kFloorWindow_s) : NoiseVariance(ch.t, e);
  };
  res.noise_rms = std::sqrt(floor_variance(an.y()));

  // Evaluate every candidate; per effect family keep the member with the smallest in-sample SSE.
  std::vector<Evaluated> all;
  all.reserve(ch.candidates.size());
  for (const Candidate& c : ch.candidates) {
    double energy = 0;
    for (const auto& x : c.X) energy += x.squaredNorm();
    if (!(energy > 1e-18)) continue;
    Evaluated e = an.Evaluate(c);
    if (e.full.ok) all.push_back(std::move(e));
  }
  std::map<std::string, std::vector<size_t>> family;
  for (size_t i = 0; i < all.size(); ++i) family[all[i].cand->effect].push_back(i);
  std::vector<std::string> fam_names;
  std::vector<size_t> fam_best;
  for (const auto& [name, members] : family) {
    size_t best = members[0];
    for (size_t m : members) {
      if (all[m].full.sse < all[best].full.sse) best = m;
    }
    fam_names.push_back(name);
    fam_best.push_back(best);
  }
  const size_t F = fam_names.size();

  // Block bootstrap: which family wins the information criterion on resampled blocks.
  const int G = an.G();
  std::vector<double> wins(F, 0.0);
  std::map<std::string, std::vector<double>> grid_boot;
  for (int b = 0; b < o.bootstrap_samples; ++b) {
    std::vector<double> w(G, 0.0);
    for (int k = 0; k < G; ++k) w[std::min(G - 1, static_cast<int>(rng->Uniform() * G))] += 1.0;
    double n_w = 0, base = 0;
    for (int k = 0; k < G; ++k) {
      n_w += w[k] * an.base_n()[k];
      base += w[k] * an.base_blocks()[k];
    }
    double best_bic = n_w * std::log(std::max(base, 1e-300) / n_w);
    int winner = -1;
    for (size_t f = 0; f < F; ++f) {
      double fam_bic = 1e300;
      double fam_grid = 0;
      for (size_t m : family[fam_names[f]]) {
        const Fit fit = Solve(all[m].blocks, w, all[m].cand->p());
        if (!fit.ok) continue;
        const double bic = n_w * std::log(std::max(fit.sse, 1e-300) / n_w) + all[m].cand->p() * std::log(n_w);
        if (bic < fam_bic) {
          fam_bic = bic;
          fam_grid = all[m].cand->grid_value;
        }
      }
      if (!all[fam_best[f]].cand->grid_name.empty()) grid_boot[fam_names[f]].push_back(fam_grid);
      if (fam_bic < best_bic) {
        best_bic = fam_bic;
        winner = static_cast<int>(f);
      }
    }
    if (winner >= 0) wins[winner] += 1;
  }

  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = all[fam_best[f]];
    CandidateResult r;
    r.effect = fam_names[f];
    r.probability = o.bootstrap_samples > 0 ? wins[f] / o.bootstrap_samples : 0.0;
    r.heldout_shrink = Shrink(e.cv_sse, an.base_sse());
    r.p_value = std::min(1.0, e.p_value);
    r.bic = e.bic;
    Describe(e, grid_boot[fam_names[f]], &r);
    if (r.effect == "latency" && ch.known_hold_max_s > 0) {
      // Report the total latency: the known sample hold removed in the replay plus the excess.
      r.magnitude += ch.known_hold_s;
      r.magnitude_ci95[0] += ch.known_hold_s;
      r.magnitude_ci95[1] += ch.known_hold_s;
      r.params["latency_s"] = r.magnitude;
      r.ci95["latency_s"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
      r.params["known_sample_hold_s"] = ch.known_hold_s;
    }
    if (r.effect == "ground_effect") {
      // The linear parameter is a = R²; report the effective radius R (monotone: interval maps).
      const double a = r.params.value("radius_sq_m2", 0.0);
      r.magnitude = std::sqrt(std::max(0.0, a));
      r.magnitude_ci95[0] = std::sqrt(std::max(0.0, r.magnitude_ci95[0]));
      r.magnitude_ci95[1] = std::sqrt(std::max(0.0, r.magnitude_ci95[1]));
      r.magnitude_unit = "m";
      r.params["radius_m"] = r.magnitude;
      r.ci95["radius_m"] = {r.magnitude_ci95[0], r.magnitude_ci95[1]};
    }
    res.candidates.push_back(std::move(r));
  }
  std::vector<size_t> order(F);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return res.candidates[a].heldout_shrink > res.candidates[b].heldout_shrink;
  });

  // Is there a gap at all? A gap exists when some physical candidate's parameters are significantly
  // non-zero by the cluster-robust Wald test (Bonferroni over the families, and over the grid of a
  // profiled family), that candidate also lowers the held-out residual, and the residual exceeds
  // the high-frequency noise floor. The residual's whiteness (Ljung–Box) is reported, not used: the
  // configured models leave a coloured but unstructured residual (the current is logged at the row
  // rate, the compass samples between rows), which is part of the noise floor a real log has too.
  const double noise_var = floor_variance(an.y());
  const double ms_before = MeanSquare(an.y());
  res.noise_floor_ratio = noise_var > 0 ? ms_before / noise_var : 0.0;
  const double floor_margin = 1.0 + 6.0 / std::sqrt(std::max(1.0, an.total_n()));
  const bool above_floor = res.noise_floor_ratio > floor_margin;
  double p_cand = 1.0;
  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = all[fam_best[f]];
    const double pf = std::min(1.0, e.wald_p * static_cast<double>(family[fam_names[f]].size()));
    res.candidates[f].p_value = pf;
    bool lowers = res.candidates[f].heldout_shrink > 0;
    if (ch.explain_above_noise) {
      // Material: removes at least kMinMaterialShare of the held-out residual above the noise floor
      // (the replay's own unresolvable part, e.g. commands between log rows, is not a gap).
      constexpr double kMinMaterialShare = 0.1;
      const double ms0 = an.base_sse() / an.total_n();
      const double excess = ms0 - noise_var;
      lowers = excess > 0 && (ms0 - e.cv_sse / an.total_n()) / excess >= kMinMaterialShare;
    }
    if (lowers) p_cand = std::min(p_cand, pf * static_cast<double>(F));
  }
  double p_lb = 1.0;
  constexpr int kLjungBoxLags = 20;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    for (const auto& v : an.y()) x.push_back(v[axis]);
    p_lb = std::min(p_lb, 3.0 * internal::LjungBoxP(x, kLjungBoxLags));
  }
  res.ljung_box_p = std::min(1.0, p_lb);
  res.p_value = std::min(1.0, p_cand);
  res.gap_detected = res.p_value < o.alpha && above_floor;

  std::vector<Vec3> after = an.y();
  if (!res.gap_detected || F == 0) {
    res.verdict = "none";
    if (F == 0) {
      res.explanation = "no candidate effect could be formed for this channel";
    } else if (res.p_value < o.alpha) {
      res.explanation = fmt::format("a candidate is statistically significant, but the residual is only {:.1f} % above "
                                    "its noise floor: no material gap",
                                    100 * (res.noise_floor_ratio - 1));
    } else {
      res.explanation = "residual is consistent with the configured noise: no significant gap";
    }
  } else {
    const size_t b1 = order[0];
    const Evaluated& e1 = all[fam_best[b1]];
    Candidate chosen = *e1.cand;
    Evaluated chosen_eval = an.Evaluate(chosen);
    double chosen_cv = e1.cv_sse;
    res.candidates[b1].selected = true;
    std::string second;
    // Forward step: a second effect that significantly improves the held-out fit.
    double best_cv = chosen_cv;
    size_t b2 = F;
    Evaluated joint_best;
    Candidate joint_cand;
    for (size_t idx = 1; idx < F; ++idx) {
      const size_t f = order[idx];
      if (res.candidates[f].p_value * F > o.alpha) continue;
      Candidate j = Join(*e1.cand, *all[fam_best[f]].cand);
      Evaluated ej = an.Evaluate(j);
      if (!ej.full.ok) continue;
      const double p_partial =
          WaldP(ej.full.beta, ej.cov, Range(e1.cand->p(), j.p()), G) * static_cast<double>(F) *
          static_cast<double>(family[fam_names[f]].size());
      if (p_partial < o.alpha && ej.cv_sse < 0.9 * chosen_cv && ej.cv_sse < best_cv) {
        best_cv = ej.cv_sse;
        b2 = f;
        joint_cand = std::move(j);
        joint_best = ej;
      }
    }
    if (b2 < F) {
      res.candidates[b2].selected = true;
      chosen = joint_cand;
      chosen_eval = an.Evaluate(chosen);
      chosen_cv = best_cv;
      second = fam_names[b2];
    }
    res.heldout_shrink = Shrink(chosen_cv, an.base_sse());
    after = an.After(chosen_eval);
    const double ratio = MeanSquare(after) / std::max(1e-300, NoiseVariance(ch.t, after));
    const std::string top = fam_names[b1];
    res.chosen_regressor_name = e1.cand->regressor_name;
    res.chosen_regressor = e1.cand->regressor;
    // Share of the residual explained: of the whole mean square (1 − (1 − shrink)²), or, for
    // channels whose effects are phase-confined, of the part above the noise floor.
    bool explained = res.candidates[b1].heldout_shrink >= o.explain_shrink;
    if (ch.explain_above_noise) {
      const double ms0 = an.base_sse() / an.total_n();
      const double ms_cv = e1.cv_sse / an.total_n();
      const double excess = ms0 - noise_var;
      const double target = 1.0 - (1.0 - o.explain_shrink) * (1.0 - o.explain_shrink);  // 0.5 by default
      explained = excess > 0 && (ms0 - ms_cv) / excess >= target;
    }
    if (!explained) {
      res.verdict = "unexplained";
      res.explanation = fmt::format("no candidate removes half the held-out residual mean square{} (best: {}, shrink {:.0f} %)",
                                    ch.explain_above_noise ? " above the noise floor" : "", top,
                                    100 * res.candidates[b1].heldout_shrink);
    } else if (!ch.explain_above_noise && ratio > o.adequacy_ratio) {
      res.verdict = "unexplained";
      res.explanation = fmt::format("best partial explanation {}{} (held-out shrink {:.0f} %) leaves a structured residual "
                                    "{:.1f}x the noise power: the cause is not in the library in this form",
                                    top, second.empty() ? "" : " + " + second, 100 * res.heldout_shrink, ratio);
    } else {
      res.verdict = top;
      // Ambiguity: the bootstrap cannot separate the best from a rival.
      size_t rival = F;
      for (size_t f = 0; f < F; ++f) {
        if (f != b1 && fam_names[f] != second &&
            (rival == F || res.candidates[f].probability > res.candidates[rival].probability)) {
          rival = f;
        }
      }
      if (rival < F && res.candidates[b1].probability < 0.7 && res.candidates[rival].probability >= 0.2) {
        res.verdict = "ambiguous";
        res.explanation = fmt::format("{} (p={:.2f}) and {} (p={:.2f}) explain the data about equally: {}", top,
                                      res.candidates[b1].probability, fam_names[rival],
                                      res.candidates[rival].probability, SeparatingManoeuvre(top, fam_names[rival]));
      } else {
        res.explanation = second.empty() ? "" : "together with " + second;
      }
    }
  }
  res.residual_after = after;
  res.where = Where(ch, an.y(), log, phases);
  // Best first: selected, then by held-out shrink.
  std::vector<CandidateResult> sorted;
  for (size_t i : order) {
    if (res.candidates[i].selected) sorted.push_back(res.candidates[i]);
  }
  for (size_t i : order) {
    if (!res.candidates[i].selected) sorted.push_back(res.candidates[i]);
  }
  res.candidates = std::move(sorted);
  return res;
}

}  // namespace

std::vector<std::string> ClassifyPhases(const logs::FlightLog& log) {
  const size_t n = log.rows();
  std::vector<std::string> ph(n, "unknown");
  const bool has_pos = log.Has("pos_D_m");
  const bool has_vel = log.Has("vel_N_mps") && log.Has("vel_E_mps") && log.Has("vel_D_mps");
  if (!has_pos && !log.Has("baro_alt_m")) return ph;
  const auto& alt_src = has_pos ? log.Column("pos_D_m") : log.Column("baro_alt_m");
  const double sign = has_pos ? -1.0 : 1.0;  // height up
  double h0 = std::nan("");
  for (double v : alt_src) {
    if (std::isfinite(v)) {
      h0 = sign * v;
      break;
    }
  }
  constexpr double kAirborne_m = 0.3, kNearGround_m = 2.0, kVertical_mps = 0.5, kCruise_mps = 1.0;
  const auto& t = log.Column("t_s");
  for (size_t i = 0; i < n; ++i) {
    const double h = sign * alt_src[i] - h0;
    double vu = 0, vh = 0;
    if (has_vel) {
      vu = -log.Column("vel_D_mps")[i];
      vh = std::hypot(log.Column("vel_N_mps")[i], log.Column("vel_E_mps")[i]);
    } else if (i > 0 && i + 1 < n && t[i + 1] > t[i - 1]) {
      vu = sign * (alt_src[i + 1] - alt_src[i - 1]) / (t[i + 1] - t[i - 1]);
    }
    if (!std::isfinite(h)) continue;
    if (!std::isfinite(vu)) vu = 0;
    if (!std::isfinite(vh)) vh = 0;
    if (h < kAirborne_m && std::fabs(vu) < kAirborne_m) ph[i] = "ground";
    else if (h < kNearGround_m && vu > 0.1) ph[i] = "takeoff";
    else if (h < kNearGround_m && vu < -0.1) ph[i] = "landing";
    else if (vu > kVertical_mps) ph[i] = "climb";
    else if (vu < -kVertical_mps) ph[i] = "descent";
    else if (vh > kCruise_mps) ph[i] = "cruise";
    else ph[i] = "hover";
  }
  return ph;
}

Result<GapReport> Diagnose(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle,
                           const DiagnoseOptions& options) {
  if (log.rows() == 0) return Status::BadInput("log: no rows");
  if (!log.Has("t_s")) return Status::BadInput("log: t_s: column missing");
  GapReport rep;
  rep.log_name = log.meta.value("source", std::string("log"));
  for (const char* e : kEffectsNotBuilt) rep.effects_not_built.emplace_back(e);
  const auto& t = log.Column("t_s");
  const double duration = t.back() - t.front();
  const std::vector<std::string> phases = ClassifyPhases(log);
  for (size_t i = 0; i < phases.size();) {
    size_t j = i;
    while (j < phases.size() && phases[j] == phases[i]) ++j;
    rep.phases.push_back({t[i], t[j - 1], phases[i]});
    i = j;
  }
  internal::ReplayResult rr = internal::Replay(log, vehicle, options);
  rep.attitude_source = rr.attitude_source;
  rep.field_model = rr.field_model;
  rep.earth_field_N_uT = rr.earth_field_N_uT;
  rep.not_diagnosed = rr.not_diagnosed;
  RngStream rng(options.seed, "gap_bootstrap");
  for (const ChannelData& ch : rr.channels) {
    if (!(duration >= options.min_duration_s)) {
      rep.not_diagnosed.emplace_back(ch.name, fmt::format("log too short: {:.1f} s, needs {:.0f} s", duration, options.min_duration_s));
      continue;
    }
    if (static_cast<int>(ch.t.size()) < options.min_samples) {
      rep.not_diagnosed.emplace_back(ch.name, fmt::format("too few samples: {}, needs {}", ch.t.size(), options.min_samples));
      continue;
    }
    ChannelResult r = Analyze(ch, log, phases, options, &rng);
    r.reference_contaminated = ch.name == rr.contaminated;
    if (!ch.note.empty()) r.explanation += (r.explanation.empty() ? "" : "; ") + ch.note;
    if (r.reference_contaminated) {
      r.explanation += (r.explanation.empty() ? "" : "; ") +
                       std::string("the attitude reference fused this compass, so part of its error is absorbed into the "
                                   "reference: diagnose the other compasses against it");
    }
    rep.channels.push_back(std::move(r));
  }
  return rep;
}

nlohmann::json ToJson(const GapReport& r) {
  nlohmann::json j;
  j["schema"] = "hexsim.gap/1";
  j["log"] = r.log_name;
  j["attitude_source"] = r.attitude_source;
  j["field_model"] = r.field_model;
  j["earth_field_N_uT"] = {r.earth_field_N_uT.x(), r.earth_field_N_uT.y(), r.earth_field_N_uT.z()};
  j["channels"] = nlohmann::json::array();
  for (const auto& c : r.channels) {
    nlohmann::json cj;
    cj["channel"] = c.channel;
    cj["unit"] = c.unit;
    cj["samples"] = c.samples;
    cj["rms_before"] = c.rms_before;
    cj["noise_rms"] = c.noise_rms;
    cj["noise_floor_ratio"] = c.noise_floor_ratio;
    cj["gap_detected"] = c.gap_detected;
    cj["p_value"] = c.p_value;
    cj["ljung_box_p"] = c.ljung_box_p;
    cj["reference_contaminated"] = c.reference_contaminated;
    cj["where"] = c.where;
    cj["verdict"] = c.verdict;
    cj["explanation"] = c.explanation;
    cj["candidates"] = nlohmann::json::array();
    for (const auto& k : c.candidates) {
      cj["candidates"].push_back({{"effect", k.effect},
                                  {"probability", k.probability},
                                  {"params", k.params},
                                  {"ci95", k.ci95},
                                  {"heldout_shrink", k.heldout_shrink},
                                  {"p_value", k.p_value},
                                  {"magnitude", k.magnitude},
                                  {"magnitude_ci95", {k.magnitude_ci95[0], k.magnitude_ci95[1]}},
                                  {"magnitude_unit", k.magnitude_unit},
                                  {"selected", k.selected}});
    }
    cj["heldout_shrink"] = c.heldout_shrink;
    cj["not_available"] = c.not_available;
    j["channels"].push_back(cj);
  }
  j["not_diagnosed"] = nlohmann::json::array();
  for (const auto& [ch, why] : r.not_diagnosed) j["not_diagnosed"].push_back({{"channel", ch}, {"why", why}});
  j["phases"] = nlohmann::json::array();
  for (const auto& p : r.phases) j["phases"].push_back({{"phase", p.phase}, {"t0_s", p.t0_s}, {"t1_s", p.t1_s}});
  j["effects_not_built"] = r.effects_not_built;
  return j;
}

std::string Summary(const GapReport& r) {
  std::string s;
  for (const auto& c : r.channels) {
    const bool mag = c.unit == "uT";
    const double k = mag ? 10.0 : 1.0;  // µT → mG
    const std::string unit = mag ? "mG" : c.unit;
    s += fmt::format("{}: residual {:.3g} {} RMS (noise {:.2g})", c.channel, c.rms_before * k, unit, c.noise_rms * k);
    if (c.reference_contaminated) s += " [reference-contaminated]";
    if (!c.gap_detected) {
      s += fmt::format("; no significant gap (p = {:.2g}, residual/noise-floor power {:.2f})\n", c.p_value,
                       c.noise_floor_ratio);
      continue;
    }
    const std::string phase = c.where.value("phase", nlohmann::json::object()).value("concentrated", std::string());
    const std::string regime = c.where.value("regime", nlohmann::json::object()).value("concentrated", std::string());
    s += fmt::format(", largest in {}", phase.empty() ? "?" : phase);
    if (!regime.empty() && regime != "uniform") s += ", concentrated at " + regime;
    if (!c.candidates.empty()) {
      const auto& b = c.candidates.front();
      std::string mag_txt = fmt::format("{:.3g} [{:.3g}, {:.3g}] {}", b.magnitude, b.magnitude_ci95[0], b.magnitude_ci95[1],
                                        b.magnitude_unit);
      if (b.magnitude_unit == "uT/A") {
        mag_txt = fmt::format("{:.2f} [{:.2f}, {:.2f}] mG/A", 10 * b.magnitude, 10 * b.magnitude_ci95[0], 10 * b.magnitude_ci95[1]);
      }
      s += fmt::format("; verdict: {}; best explanation: {} {} (probability {:.2f}); held-out residual shrinks {:.0f} %",
                       c.verdict, b.effect, mag_txt, b.probability, 100 * c.heldout_shrink);
    }
    if (!c.explanation.empty()) s += " (" + c.explanation + ")";
    s += "\n";
  }
  for (const auto& [ch, why] : r.not_diagnosed) s += fmt::format("{}: not diagnosed: {}\n", ch, why);
  return s;
}

}  // namespace hexsim::gap
