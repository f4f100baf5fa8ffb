#include "mavlink/simulated_vehicle.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/error.hpp"
#include "mavlink/ned_frame.hpp"

namespace ridgeline::mavlink {

SimulatedVehicle::SimulatedVehicle(const SimulatedVehicleOptions& options) : o_(options) {
  const std::pair<const char*, double> periods[] = {
      {"integration_step_s", o_.integration_step_s},
      {"report_period_s", o_.report_period_s},
      {"heartbeat_period_s", o_.heartbeat_period_s},
      {"setpoint_timeout_s", o_.setpoint_timeout_s}};
  for (const auto& [name, value] : periods)
    if (!(value > 0.0) || !std::isfinite(value))
      throw InputError(name, fmt::format("{} must be a positive number of seconds", value));
  if (!o_.initial_state.allFinite())
    throw InputError("initial_state", "has a value that is not finite");
  if (!(o_.offboard_entry_speed_m_s >= 0.0) || !std::isfinite(o_.offboard_entry_speed_m_s))
    throw InputError("offboard_entry_speed_m_s",
                     fmt::format("{} must be a speed >= 0", o_.offboard_entry_speed_m_s));
  if (!std::isfinite(o_.home_altitude_m))
    throw InputError("home_altitude_m", fmt::format("{} is not finite", o_.home_altitude_m));
  state_ = o_.initial_state;
  state_[vehicle::kV] = state_[vehicle::kOmega] = state_[vehicle::kW] = 0.0;
  if (o_.wind) wind_.emplace(*o_.wind);
}

Vec3 SimulatedVehicle::wind_at_vehicle() const {
  if (!wind_ || !armed_ || !offboard_ || holding_) return Vec3::Zero();
  return wind_->at(state_.head<3>(), t_);
}

FrameHeader SimulatedVehicle::next_header() {
  return {sequence_++, o_.system_id, o_.component_id, 0};
}

Heartbeat SimulatedVehicle::heartbeat() const {
  Heartbeat h;
  h.type = kMavTypeHexarotor;
  h.autopilot = kMavAutopilotPx4;
  h.base_mode = static_cast<std::uint8_t>(kModeFlagCustomModeEnabled |
                                          (armed_ ? kModeFlagSafetyArmed : 0));
  h.custom_mode = offboard_ ? kPx4CustomModeOffboard : 0;
  h.system_status = armed_ ? kMavStateActive : kMavStateStandby;
  h.mavlink_version = 3;
  return h;
}

void SimulatedVehicle::integrate_to(double t_s) {
  while (t_ < t_s) {
    const double dt = std::min(o_.integration_step_s, t_s - t_);
    // Sub-nanosecond remainders come from floating-point time sums (as in mission::TruthWorld).
    if (dt < 1e-9) {
      t_ = t_s;
      break;
    }
    if (offboard_ && t_ - last_setpoint_s_ > o_.setpoint_timeout_s) {
      offboard_ = false;  // PX4's offboard loss failsafe: hold
      ++stats_.offboard_timeouts;
    }
    if (armed_ && offboard_ && !holding_) {
      state_ = vehicle::rk4_step(state_, command_, wind_at_vehicle(), o_.params, dt);
    } else {
      state_[vehicle::kV] = state_[vehicle::kOmega] = state_[vehicle::kW] = 0.0;
    }
    t_ += dt;
  }
}

void SimulatedVehicle::handle_setpoint(const SetPositionTargetLocalNed& sp, double t_s) {
  const SetpointCommand c = command_from_setpoint(sp, o_.home_altitude_m);
  if (!c.error.empty()) {
    ++stats_.setpoints_rejected;
    stats_.last_error = "SET_POSITION_TARGET_LOCAL_NED." + c.error;
    return;
  }
  const bool flying = armed_ && offboard_;
  if (c.hold_position_enu_m) {
    const double off = (*c.hold_position_enu_m - state_.head<3>()).norm();
    if (off > o_.hold_tolerance_m) {
      ++stats_.setpoints_rejected;
      stats_.last_error = fmt::format(
          "SET_POSITION_TARGET_LOCAL_NED.x/y/z: a hold {:.1f} m away; this vehicle holds only "
          "where it is (within {} m)",
          off, o_.hold_tolerance_m);
      return;
    }
    ++stats_.setpoints;
    last_setpoint_s_ = t_s;
    if (flying && !holding_) {
      holding_ = true;
      ++stats_.holds;
      state_[vehicle::kV] = state_[vehicle::kOmega] = state_[vehicle::kW] = 0.0;
    }
    return;
  }
  ++stats_.setpoints;
  if (holding_) {
    // Leaving a hold at the commanded speed (mission::TruthWorld::release).
    holding_ = false;
    state_[vehicle::kV] = (*c.command)[vehicle::kSpeedCmd];
    state_[vehicle::kOmega] = state_[vehicle::kW] = 0.0;
  }
  command_ = vehicle::clamp_to_limits(*c.command, state_, o_.params);
  last_setpoint_s_ = t_s;
}

void SimulatedVehicle::handle(const Message& message, double t_s) {
  integrate_to(t_s);
  if (const auto* sp = std::get_if<SetPositionTargetLocalNed>(&message)) {
    handle_setpoint(*sp, t_s);
  } else if (const auto* cmd = std::get_if<CommandLong>(&message)) {
    handle_command(*cmd, t_s);
  }
}

void SimulatedVehicle::handle_command(const CommandLong& c, double t_s) {
  ++stats_.commands;
  if (c.target_system != o_.system_id && c.target_system != 0) return;  // not for us
  // A change of arming or mode is announced with the next report, not a second later.
  struct AnnounceChange {
    SimulatedVehicle& v;
    bool armed, offboard;
    ~AnnounceChange() {
      if (v.armed_ != armed || v.offboard_ != offboard) v.next_heartbeat_s_ = v.t_;
      if (v.armed_ && v.offboard_ && !(armed && offboard)) {
        v.holding_ = false;
        v.state_[vehicle::kV] = v.o_.offboard_entry_speed_m_s;
      }
    }
  } announce{*this, armed_, offboard_};
  auto refuse = [&](std::string why) {
    ++stats_.commands_refused;
    stats_.last_error = fmt::format("COMMAND_LONG {}: {}", c.command, why);
  };
  if (c.command == kMavCmdComponentArmDisarm) {
    if (c.param1 == 1.0f) {
      armed_ = true;
    } else if (c.param1 == 0.0f) {
      armed_ = false;
      offboard_ = false;
    } else {
      refuse(fmt::format("param1 {} is neither 1 (arm) nor 0 (disarm)", c.param1));
    }
  } else if (c.command == kMavCmdDoSetMode) {
    const bool custom = (static_cast<int>(c.param1) & kModeFlagCustomModeEnabled) != 0;
    if (!custom || c.param2 != static_cast<float>(kPx4MainModeOffboard)) {
      refuse(fmt::format("mode (param1 {}, param2 {}) is not PX4 offboard (1, 6)", c.param1,
                         c.param2));
    } else if (t_s - last_setpoint_s_ > o_.setpoint_timeout_s) {
      refuse("offboard refused: no setpoint stream (send SET_POSITION_TARGET_LOCAL_NED first)");
    } else {
      offboard_ = true;
    }
  } else {
    refuse("unsupported command");
  }
}

void SimulatedVehicle::advance(double t_s, std::vector<EncodedFrame>& out) {
  std::vector<Message> messages;
  advance(t_s, messages);
  for (const Message& m : messages) out.push_back(encode_message(m, next_header()));
}

void SimulatedVehicle::advance(double t_s, std::vector<Message>& out) {
  integrate_to(t_s);
  if (t_s >= next_heartbeat_s_) {
    out.push_back(heartbeat());
    next_heartbeat_s_ += o_.heartbeat_period_s;
    if (next_heartbeat_s_ <= t_s) next_heartbeat_s_ = t_s + o_.heartbeat_period_s;
  }
  if (t_s >= next_report_s_) {
    const auto ms = static_cast<std::uint32_t>(std::llround(t_s * 1000.0));
    const StateReport r = report_state(state_, wind_at_vehicle(), ms, o_.home_altitude_m);
    out.push_back(r.position);
    out.push_back(r.attitude);
    next_report_s_ += o_.report_period_s;
    if (next_report_s_ <= t_s) next_report_s_ = t_s + o_.report_period_s;
  }
}

std::uint32_t SimulatedVehicle::lockstep_stamp_ms(std::uint64_t step, double period_s) {
  return static_cast<std::uint32_t>(std::llround(static_cast<double>(step) * period_s * 1000.0));
}

void SimulatedVehicle::handle_lockstep(const Message& message, double period_s) {
  const auto* sp = std::get_if<SetPositionTargetLocalNed>(&message);
  if (sp == nullptr) {
    if (const auto* cmd = std::get_if<CommandLong>(&message)) handle_command(*cmd, t_);
    return;
  }
  lockstep_period_s_ = period_s;
  const bool flying = armed_ && offboard_;
  const std::uint32_t now_ms = lockstep_stamp_ms(lockstep_step_, period_s);
  if (sp->time_boot_ms == kKeepAliveStamp) {
    // A keep-alive only feeds the stream; in flight (a late or resent one) it changes nothing.
    if (flying) {
      last_setpoint_s_ = t_;
    } else {
      handle_setpoint(*sp, t_);
    }
    return;
  }
  if (!flying) {
    handle_setpoint(*sp, t_);
    return;
  }
  if (sp->time_boot_ms == now_ms) {
    handle_setpoint(*sp, t_);
    ++lockstep_step_;
    ++stats_.lockstep_steps;
    // The step's end from the step count, so no rounding accumulates over a long flight.
    integrate_to(static_cast<double>(lockstep_step_) * period_s);
  } else if (lockstep_step_ > 0 &&
             sp->time_boot_ms == lockstep_stamp_ms(lockstep_step_ - 1, period_s)) {
    ++stats_.lockstep_duplicates;
  } else {
    ++stats_.lockstep_out_of_step;
    stats_.last_error = fmt::format(
        "SET_POSITION_TARGET_LOCAL_NED.time_boot_ms: {} is not this lock-step vehicle's time "
        "{} ms (or the step before)",
        sp->time_boot_ms, now_ms);
  }
}

StateReport SimulatedVehicle::lockstep_state_report() const {
  return report_state(state_, wind_at_vehicle(),
                      lockstep_stamp_ms(lockstep_step_, lockstep_period_s_), o_.home_altitude_m);
}

void SimulatedVehicle::lockstep_reply(std::vector<EncodedFrame>& out) {
  out.push_back(encode_message(heartbeat(), next_header()));
  const StateReport r = lockstep_state_report();
  out.push_back(encode_message(r.position, next_header()));
  out.push_back(encode_message(r.attitude, next_header()));
}

}  // namespace ridgeline::mavlink
