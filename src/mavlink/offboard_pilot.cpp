#include "mavlink/offboard_pilot.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "mavlink/ned_frame.hpp"

namespace ridgeline::mavlink {

std::string_view to_string(PilotPhase phase) {
  switch (phase) {
    case PilotPhase::kWaitingForState: return "waiting for the vehicle's state";
    case PilotPhase::kArming: return "arming";
    case PilotPhase::kStartingOffboard: return "starting offboard";
    case PilotPhase::kFlying: return "flying";
    case PilotPhase::kFinished: return "finished";
    case PilotPhase::kVehicleLeftOffboard: return "vehicle left offboard or disarmed";
  }
  return "invalid phase";
}

OffboardPilot::OffboardPilot(const OffboardPilotOptions& options, const world::SafetyLimits& limits,
                             std::shared_ptr<const mpc::ReferenceTrajectory> reference,
                             std::shared_ptr<const world::Terrain> terrain)
    : o_(options),
      reference_(std::move(reference)),
      terrain_(std::move(terrain)),
      tracker_(options.tracker, limits) {
  if (!reference_) throw InputError("reference", "is missing");
  if (!(o_.flight_duration_s > 0.0))
    throw InputError("flight_duration_s", "must be positive");
  if (!(o_.heartbeat_period_s > 0.0) || !(o_.command_retry_s > 0.0))
    throw InputError("heartbeat_period_s/command_retry_s", "must be positive");
}

FrameHeader OffboardPilot::next_header() {
  return {sequence_++, o_.system_id, o_.component_id, 0};
}

CommandLong OffboardPilot::command(std::uint16_t id, float param1, float param2) const {
  CommandLong c;
  c.command = id;
  c.param1 = param1;
  c.param2 = param2;
  c.target_system = o_.target_system;
  c.target_component = o_.target_component;
  return c;
}

void OffboardPilot::handle(const Message& message, double t_s) {
  if (const auto* p = std::get_if<LocalPositionNed>(&message)) {
    position_ = *p;
    have_position_ = true;
    state_time_s_ = t_s;
  } else if (const auto* a = std::get_if<Attitude>(&message)) {
    attitude_ = *a;
    have_attitude_ = true;
  } else if (const auto* h = std::get_if<Heartbeat>(&message)) {
    have_heartbeat_ = true;
    vehicle_armed_ = (h->base_mode & kModeFlagSafetyArmed) != 0;
    vehicle_offboard_ = (h->base_mode & kModeFlagCustomModeEnabled) != 0 &&
                        ((h->custom_mode >> 16) & 0xFF) == kPx4MainModeOffboard;
  }
}

void OffboardPilot::tick(double t_s, std::vector<EncodedFrame>& out) {
  std::vector<Message> messages;
  tick(t_s, messages);
  for (const Message& m : messages) out.push_back(encode_message(m, next_header()));
}

void OffboardPilot::tick(double t_s, std::vector<Message>& out) {
  if (first_tick_s_ < 0.0) first_tick_s_ = t_s;
  if (done()) return;
  if (t_s >= next_heartbeat_s_) {
    Heartbeat h;
    h.type = kMavTypeOnboardController;
    h.autopilot = kMavAutopilotInvalid;
    h.system_status = kMavStateActive;
    out.push_back(h);
    next_heartbeat_s_ = t_s + o_.heartbeat_period_s;
  }
  if (!have_position_ || !have_attitude_) return;
  const vehicle::State state = state_from_report(position_, attitude_, o_.home_altitude_m);
  const std::uint32_t ms = static_cast<std::uint32_t>(std::llround((t_s - first_tick_s_) * 1e3));

  if (phase_ == PilotPhase::kFlying && (!vehicle_armed_ || !vehicle_offboard_)) {
    phase_ = PilotPhase::kVehicleLeftOffboard;
    return;
  }
  if (phase_ != PilotPhase::kFlying) {
    const mpc::ReferencePoint r0 = reference_->at(0.0);
    last_command_ = vehicle::Input(r0.speed_m_s, 0.0, 0.0);
    if (!have_heartbeat_ || !vehicle_armed_) {
      phase_ = PilotPhase::kArming;
      if (t_s >= next_command_s_) {
        out.push_back(command(kMavCmdComponentArmDisarm, 1.0f, 0.0f));
        next_command_s_ = t_s + o_.command_retry_s;
      }
    } else if (!vehicle_offboard_) {
      if (phase_ != PilotPhase::kStartingOffboard) next_command_s_ = t_s;  // armed: go on now
      phase_ = PilotPhase::kStartingOffboard;
      if (t_s >= next_command_s_) {
        out.push_back(command(kMavCmdDoSetMode, static_cast<float>(kModeFlagCustomModeEnabled),
                              static_cast<float>(kPx4MainModeOffboard)));
        next_command_s_ = t_s + o_.command_retry_s;
      }
    } else {
      phase_ = PilotPhase::kFlying;
      flight_start_s_ = t_s;
      tracker_.reset(last_command_);
    }
  }
  if (phase_ == PilotPhase::kFlying) {
    const double t = t_s - flight_start_s_;
    if (t >= o_.flight_duration_s) {
      phase_ = PilotPhase::kFinished;
      return;
    }
    if (t_s - state_time_s_ > o_.state_timeout_s) ++stale_steps_;
    const mpc::TrackerEnvironment env{{}, {}, terrain_.get()};
    const mpc::UavTrackerResult& r = tracker_.step(t, state, Vec3::Zero(), *reference_, env);
    if (r.fallback) ++qp_fallbacks_;
    last_command_ = r.command;
    log_.push_back({t, state.head<3>(), reference_->at(t).position_m, r.command});
  }
  out.push_back(velocity_setpoint(last_command_, state[vehicle::kPsi], ms, o_.target_system,
                                  o_.target_component));
}

FlightSummary OffboardPilot::summary() const {
  FlightSummary s;
  s.phase = phase_;
  s.steps = static_cast<int>(log_.size());
  s.stale_steps = stale_steps_;
  s.qp_fallbacks = qp_fallbacks_;
  double sum = 0.0;
  for (std::size_t i = 0; i < log_.size(); ++i) {
    const double e = (log_[i].position_m - log_[i].reference_m).norm();
    sum += e * e;
    s.tracking_max_m = std::max(s.tracking_max_m, e);
    if (i > 0) s.path_length_m += (log_[i].position_m - log_[i - 1].position_m).norm();
  }
  if (!log_.empty()) {
    s.tracking_rmse_m = std::sqrt(sum / static_cast<double>(log_.size()));
    s.flown_time_s = log_.back().t_s;
    s.time_to_offboard_s = flight_start_s_ - first_tick_s_;
  }
  return s;
}

}  // namespace ridgeline::mavlink
