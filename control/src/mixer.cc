#include "hexsim/control/mixer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/SVD>

#include "hexsim/common/format.h"
#include "hexsim/common/rotation.h"

namespace hexsim::control {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::Vector4d;
using Eigen::VectorXd;

MatrixXd AllocationMatrix(const std::vector<RotorGeometry>& rotors) {
  MatrixXd A(4, static_cast<Eigen::Index>(rotors.size()));
  for (size_t i = 0; i < rotors.size(); ++i) {
    const RotorGeometry& r = rotors[i];
    const Vector3d a = r.thrust_axis_B.normalized();
    const Vector3d tau = r.p_B_m.cross(a) - r.spin * r.torque_to_thrust_m * a;
    A(0, static_cast<Eigen::Index>(i)) = -a.z();
    A.block<3, 1>(1, static_cast<Eigen::Index>(i)) = tau;
  }
  return A;
}

Result<Mixer> Mixer::Create(const std::vector<RotorGeometry>& rotors) {
  if (rotors.size() < 4) return Status::BadInput(Format("rotors: need at least 4 (got %zu)", rotors.size()));
  for (size_t i = 0; i < rotors.size(); ++i) {
    if (!(rotors[i].thrust_axis_B.norm() > 1e-9) || !rotors[i].p_B_m.allFinite()) {
      return Status::BadInput(Format("rotors[%zu].thrust_axis_B: must be a finite non-zero vector", i));
    }
    if (rotors[i].spin != 1 && rotors[i].spin != -1) {
      return Status::BadInput(Format("rotors[%zu].spin: must be +1 or -1 (got %d)", i, rotors[i].spin));
    }
  }
  MatrixXd A = AllocationMatrix(rotors);
  Eigen::JacobiSVD<MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const VectorXd& s = svd.singularValues();
  if (s(3) < 1e-9 * std::max(1.0, s(0))) {
    return Status::BadInput("rotors: the layout cannot produce thrust, roll, pitch and yaw independently");
  }
  const MatrixXd A_pinv = svd.matrixV() * s.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
  return Mixer(std::move(A), A_pinv);
}

namespace {

// Interval [lo, hi] of c such that 0 <= base_i + c·d_i <= max for every rotor (d_i may be any sign);
// base_i = scale·rp_i. Element by element, so the mixer allocates no temporaries per call.
void FeasibleShift(double scale, const Eigen::Ref<const VectorXd>& rp, const Eigen::Ref<const VectorXd>& d,
                   double max, double* lo, double* hi) {
  *lo = -std::numeric_limits<double>::infinity();
  *hi = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < rp.size(); ++i) {
    const double base = scale * rp(i);
    if (std::abs(d(i)) < 1e-12) {
      if (base < -1e-9 || base > max + 1e-9) *lo = std::numeric_limits<double>::infinity();
      continue;
    }
    const double a = -base / d(i), b = (max - base) / d(i);
    *lo = std::max(*lo, std::min(a, b));
    *hi = std::min(*hi, std::max(a, b));
  }
}

}  // namespace

MixResult Mixer::Mix(double thrust_N, const Vector3d& torque_B_Nm, double max_rotor_thrust_N) const {
  MixResult out;
  Mix(thrust_N, torque_B_Nm, max_rotor_thrust_N, &out);
  return out;
}

void Mixer::Mix(double thrust_N, const Vector3d& torque_B_Nm, double max_rotor_thrust_N, MixResult* out_ptr) const {
  HEXSIM_CHECK(max_rotor_thrust_N > 0.0);
  HEXSIM_CHECK(out_ptr != nullptr);
  MixResult& out = *out_ptr;
  const auto d = A_pinv_.col(0);  // rotor thrusts per newton of collective
  // The roll/pitch part rp and the yaw part are formed per rotor below (no temporaries). The
  // rotor thrusts are built in out.thrust_N, whose storage a caller may keep across calls.
  const auto rp_i = [&](Eigen::Index i) {
    return A_pinv_(i, 1) * torque_B_Nm.x() + A_pinv_(i, 2) * torque_B_Nm.y();
  };
  const auto yaw_i = [&](Eigen::Index i) { return A_pinv_(i, 3) * torque_B_Nm.z(); };
  const Eigen::Index n = A_pinv_.rows();
  const double max = max_rotor_thrust_N;
  VectorXd& t = out.thrust_N;
  t.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) t(i) = rp_i(i);
  const VectorXd& rp = t;  // holds rp until step 2 overwrites it

  // 1. Roll/pitch first: the collective c may move anywhere that keeps rp + c·d in bounds. If no c
  //    fits, scale roll/pitch down by the largest factor for which one does (bisection; the feasible
  //    set in the factor is an interval containing 0).
  double lo = 0.0, hi = 0.0, k = 1.0;
  FeasibleShift(1.0, rp, d, max, &lo, &hi);
  if (lo > hi) {
    double k_ok = 0.0, k_bad = 1.0;
    for (int it = 0; it < 50; ++it) {
      const double km = 0.5 * (k_ok + k_bad);
      FeasibleShift(km, rp, d, max, &lo, &hi);
      (lo <= hi ? k_ok : k_bad) = km;
    }
    k = k_ok;
    FeasibleShift(k, rp, d, max, &lo, &hi);
  }
  out.roll_pitch_scale = k;
  // 2. Collective: as requested, shifted into the interval that keeps roll/pitch.
  const double c = std::clamp(thrust_N, lo, hi);
  for (Eigen::Index i = 0; i < n; ++i) t(i) = k * t(i) + c * d(i);  // t = k·rp + c·d
  // 3. Yaw last: the largest fraction μ in [0, 1] of the yaw part that keeps every rotor in bounds.
  double mu = 1.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double yaw = yaw_i(i);
    if (yaw > 1e-12) mu = std::min(mu, (max - t(i)) / yaw);
    if (yaw < -1e-12) mu = std::min(mu, -t(i) / yaw);
  }
  mu = std::max(mu, 0.0);
  out.yaw_scale = mu;
  for (Eigen::Index i = 0; i < n; ++i) t(i) = std::min(std::max(t(i) + mu * yaw_i(i), 0.0), max);
  // A·t with the fixed-size result (a 4-row product; no general matrix-vector kernel per call).
  out.achieved.setZero();
  for (Eigen::Index j = 0; j < n; ++j) out.achieved += A_.col(j).head<4>() * t(j);
  const double tol = 1e-9 * std::max(1.0, max);
  out.saturated = k < 1.0 || std::abs(c - thrust_N) > tol || mu < 1.0;
}

double ControlAmount(const VectorXd& rotor_commands) {
  if (rotor_commands.size() == 0) return 0.0;
  return 1000.0 * rotor_commands.cwiseMax(0.0).cwiseMin(1.0).mean();
}

std::vector<RotorGeometry> CircularLayout(int n, double arm_m, double first_angle_deg, int first_spin,
                                          double torque_to_thrust_m) {
  std::vector<RotorGeometry> rotors(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double ang = (first_angle_deg + 360.0 * i / n) * kDegToRad;
    RotorGeometry& r = rotors[static_cast<size_t>(i)];
    r.p_B_m = Vector3d(arm_m * std::cos(ang), arm_m * std::sin(ang), 0.0);
    r.spin = (i % 2 == 0) ? first_spin : -first_spin;
    r.torque_to_thrust_m = torque_to_thrust_m;
  }
  return rotors;
}

}  // namespace hexsim::control
