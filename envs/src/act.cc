#include "hexsim/envs/act.h"

namespace hexsim::envs {

namespace {

class ActController final : public control::Controller {
 public:
  ActController(const control::ControllerParams& params, const control::VehicleModelForControl& model,
                const Action* action)
      : cascade_(params, model), action_(action) {}

  control::ControlOutput Update(const control::NavState& state, const control::Setpoint& setpoint,
                                double dt_s) override {
    switch (action_->mode) {
      case ActMode::kAttitude:
        return cascade_.UpdateAttitude(state, action_->q_sp_NB, action_->thrust_N, 0.0, dt_s);
      case ActMode::kRates: {
        control::ControlOutput out;
        out.thrust_N = action_->thrust_N;
        out.torque_B_Nm = cascade_.UpdateRates(state, action_->w_sp_B_radps, dt_s);
        return out;
      }
      default: return cascade_.Update(state, setpoint, dt_s);
    }
  }
  void Reset() override { cascade_.Reset(); }

 private:
  control::CascadedController cascade_;
  const Action* action_;
};

}  // namespace

const char* ActModeName(ActMode mode) {
  switch (mode) {
    case ActMode::kBuiltin: return "builtin";
    case ActMode::kPosition: return "position";
    case ActMode::kAttitude: return "attitude";
    case ActMode::kRates: return "rates";
    case ActMode::kMotors: return "motors";
  }
  return "builtin";
}

sim::Plugins ActPlugins(const sim::RunSetup& setup, const Action* action) {
  sim::Plugins plugins;
  plugins.controller = std::make_unique<ActController>(setup.control, sim::ControlModelFor(setup.vehicle), action);
  plugins.setpoint_hook = [action](double, const control::NavState&, control::Setpoint* sp) {
    if (action->mode == ActMode::kBuiltin || action->mode == ActMode::kMotors) return;
    sp->idle = false;  // the caller flies: the motors run whatever the mission's state
    if (action->mode != ActMode::kPosition) return;
    sp->p_N_m = action->p_sp_N_m;
    sp->v_ff_N_mps.setZero();
    sp->a_ff_N_mps2.setZero();
    sp->yaw_rad = action->yaw_sp_rad;
    sp->yaw_rate_ff_radps = 0.0;
    sp->position_valid = true;
  };
  plugins.command_hook = [action](double, const control::NavState&, std::vector<double>* commands) {
    if (action->mode == ActMode::kMotors) *commands = action->motors;
  };
  return plugins;
}

}  // namespace hexsim::envs
