#include "swarm/agent.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include "core/error.hpp"

namespace ridgeline::swarm {

const char* to_string(AgentMode mode) {
  switch (mode) {
    case AgentMode::kTracking: return "tracking";
    case AgentMode::kFallback: return "fallback";
    case AgentMode::kFinished: return "finished";
  }
  return "unknown";
}

namespace {

void require(bool ok, const char* field, const char* reason) {
  if (!ok) throw InputError(field, reason);
}

/// The delayed plan without the detour: what a new detour is built around.
class DelayedPlan : public mpc::ReferenceTrajectory {
 public:
  explicit DelayedPlan(const AgentReference& r) : r_(r) {}
  mpc::ReferencePoint at(double t_s) const override { return r_.plan_at(t_s); }

 private:
  const AgentReference& r_;
};

}  // namespace

Agent::Agent(const AgentOptions& options, const world::SafetyLimits& limits,
             std::shared_ptr<const mpc::SampledReference> plan,
             std::shared_ptr<const world::Terrain> terrain)
    : options_(options),
      limits_(limits),
      terrain_(std::move(terrain)),
      reference_(std::make_shared<AgentReference>(std::move(plan))),
      tracker_(options.tracker, limits),
      command_rate_(options.tracker.max_speed_cmd_rate_m_s2,
                    options.tracker.max_turn_cmd_rate_rad_s2,
                    options.tracker.max_climb_cmd_rate_m_s2),
      guard_(options.separation_guard, options.tracker.vehicle, command_rate_) {
  require(options.num_uavs >= 1, "num_uavs", "must be at least 1");
  require(options.id >= 0 && options.id < options.num_uavs, "id", "must be in [0, num_uavs)");
  require(options.broadcast_period_s > 0.0, "broadcast_period_s", "must be positive");
  require(options.end_radius_m > 0.0, "end_radius_m", "must be positive");
  require(options.threat_report_period_s > 0.0, "threat_report_period_s", "must be positive");
  require(options.replan_period_s > 0.0, "replan_period_s", "must be positive");
  require(options.neighbour_lookahead_s > 0.0 && std::isfinite(options.neighbour_lookahead_s),
          "neighbour_lookahead_s", "must be positive and finite");
  require(options.neighbour_conflict_margin_m >= 0.0 &&
              std::isfinite(options.neighbour_conflict_margin_m),
          "neighbour_conflict_margin_m", "must be finite and >= 0");
  for (const auto& [value, field] :
       {std::pair{options.separation_margin_m, "separation_margin_m"},
        std::pair{options.age_margin_m_s, "age_margin_m_s"},
        std::pair{options.max_age_margin_m, "max_age_margin_m"}})
    require(value >= 0.0 && std::isfinite(value), field, "must be finite and >= 0");
  require(options.max_levels >= 0, "max_levels", "must not be negative");
  require(options.level_spacing_m > 1.0 && std::isfinite(options.level_spacing_m),
          "level_spacing_m", "must be finite and > 1 m");
  require(options.level_lookahead_s > 0.0 && options.level_lookahead_s <= 600.0,
          "level_lookahead_s", "must be in (0, 600] s");
  require(options.max_delay_s >= 0.0 && options.max_delay_s <= 600.0, "max_delay_s",
          "must be in [0, 600] s");
  require(options.delay_step_s > 0.0 && std::isfinite(options.delay_step_s), "delay_step_s",
          "must be positive and finite");
  require(options.delay_rate > 0.0 && options.delay_rate < 1.0, "delay_rate", "must be in (0, 1)");
  require(options.delay_per_level_s > 0.0 && std::isfinite(options.delay_per_level_s),
          "delay_per_level_s", "must be positive and finite");
  require(options.intent_step_s > 0.0 && std::isfinite(options.intent_step_s), "intent_step_s",
          "must be positive and finite");
  require(options.min_replan_interval_s >= 0.0 && std::isfinite(options.min_replan_interval_s),
          "min_replan_interval_s", "must be finite and >= 0");
  require(options.rejoin_distance_m > 0.0 && options.lost_reference_m > options.rejoin_distance_m,
          "lost_reference_m", "must exceed rejoin_distance_m > 0");
  require(options.position_filter_gain > 0.0 && options.position_filter_gain <= 1.0,
          "position_filter_gain", "must be in (0, 1]");
  require(options.wind_filter_time_s >= 0.0, "wind_filter_time_s", "must not be negative");
  require(options.fallback_after_failures >= 1, "fallback_after_failures", "must be at least 1");
  require(options.recover_after_successes >= 1, "recover_after_successes", "must be at least 1");
  require(terrain_ != nullptr, "terrain", "is required");
  for (const AgentTarget& target : options.targets) {
    require(target.position_m.allFinite(), "targets.position_m", "must be finite");
    require(target.radius_m > 0.0 && target.altitude_band_m > 0.0, "targets.radius_m",
            "radius and altitude band must be positive");
  }
  require(options.reapproach_after_s > 0.0 && std::isfinite(options.reapproach_after_s),
          "reapproach_after_s", "must be positive and finite");
  require(options.reapproach_lead_s >= 0.0 && std::isfinite(options.reapproach_lead_s),
          "reapproach_lead_s", "must be finite and >= 0");
  require(options.max_reapproaches >= 0, "max_reapproaches", "must not be negative");
  last_command_ = vehicle::Input(options.tracker.vehicle.cruise_speed_m_s, 0.0, 0.0);
  // Each target's pass: the plan's closest approach, searched in visiting order.
  double from = reference_->plan_start_time_s();
  const double end = reference_->plan_end_time_s();
  for (const AgentTarget& target : options_.targets) {
    double best = std::numeric_limits<double>::infinity(), best_time = from;
    for (double tp = from; tp <= end; tp += 0.2) {  // 2 m at cruise
      const double d = (reference_->plan_point(tp).position_m - target.position_m).norm();
      if (d < best) {
        best = d;
        best_time = tp;
      }
    }
    target_pass_s_.push_back(best_time);
    from = best_time;
  }
  reapproaches_.assign(options_.targets.size(), 0);
  // Before the first control(): no positions yet.
  prediction_ = std::make_shared<const Message>(
      PredictedTrajectory{options.id, 0.0, options.tracker.prediction_step_s, {}});
}

void Agent::receive(const Envelope& envelope) {
  ++counters_.messages_received;
  if (check_message(envelope.message(), options_.num_uavs).has_value() || envelope.sender < 0 ||
      envelope.sender >= options_.num_uavs || envelope.sender == options_.id) {
    ++counters_.messages_rejected;
    return;
  }
  if (const auto* p = std::get_if<PredictedTrajectory>(&envelope.message())) {
    if (p->uav != envelope.sender || p->positions_m.empty()) {
      ++counters_.messages_rejected;
      return;
    }
    auto it = neighbours_.find(p->uav);
    if (it != neighbours_.end() && it->second.prediction().stamp_s >= p->stamp_s)
      return;  // reordered
    // A neighbour this UAV yields to has moved its intent: the slot may no longer be free. A
    // re-plan that redraws the same path (a detour refreshed) changes nothing here.
    if (p->uav < options_.id && it != neighbours_.end() &&
        it->second.prediction().intent_revision != p->intent_revision) {
      constexpr double kMoved = 2.0;  // m: well below a level or the conflict margin
      const PredictedTrajectory& old = it->second.prediction();
      for (std::size_t k = 0; k < p->intent_m.size() && !neighbour_replan_requested_; ++k) {
        const double tau = p->intent_start_s + p->intent_step_s * static_cast<double>(k);
        neighbour_replan_requested_ =
            tau > old.stamp_s && (messages::expected_position(old, tau) - p->intent_m[k]).norm() > kMoved;
      }
    }
    neighbours_[p->uav].message = envelope.payload;  // shared, not copied
  } else if (const auto* r = std::get_if<ThreatReport>(&envelope.message())) {
    auto it = threats_.find(r->threat_id);
    if (it != threats_.end() && it->second.threat.appear_s >= r->stamp_s) return;
    const bool is_new = it == threats_.end();
    KnownThreat& k = threats_[r->threat_id];
    k.threat.name = fmt::format("threat{}", r->threat_id);
    k.threat.centre_m = r->centre_m;
    k.threat.velocity_m_s = r->velocity_m_s;
    k.threat.radius_m = r->radius_m;
    k.threat.appear_s = r->stamp_s;
    k.confirmed_s = std::max(k.confirmed_s, r->stamp_s);
    if (is_new) replan_requested_ = true;
  }
  // StateReport and ReferencePlan are for the ground station; an agent ignores them.
}

void Agent::sense(double t_s, std::span<const ThreatObservation> observations,
                  std::vector<Message>& outbox) {
  for (const ThreatObservation& o : observations) {
    auto it = threats_.find(o.threat_id);
    const bool is_new = it == threats_.end();
    KnownThreat& k = threats_[o.threat_id];
    k.threat.name = fmt::format("threat{}", o.threat_id);
    k.threat.centre_m = o.centre_m;
    k.threat.velocity_m_s = o.velocity_m_s;
    k.threat.radius_m = o.radius_m;
    k.threat.appear_s = t_s;
    k.confirmed_s = t_s;
    if (is_new) replan_requested_ = true;
    if (t_s - k.last_reported_s >= options_.threat_report_period_s - 1e-9) {
      k.last_reported_s = t_s;
      outbox.push_back(ThreatReport{options_.id, o.threat_id, t_s, o.centre_m, o.velocity_m_s,
                                    o.radius_m});
      ++counters_.threat_reports_sent;
    }
  }
}

std::vector<world::Threat> Agent::known_threats() const {
  std::vector<world::Threat> out;
  for (const auto& [id, k] : threats_) out.push_back(k.threat);
  return out;
}

void Agent::forget_old_threats(double t_s) {
  for (auto it = threats_.begin(); it != threats_.end();) {
    if (t_s - it->second.confirmed_s > options_.threat_forget_s) {
      it = threats_.erase(it);
    } else {
      ++it;
    }
  }
}

void Agent::update_mission(double t_s, const Vec3& position_m) {
  const int n = static_cast<int>(options_.targets.size());
  while (next_target_ < n) {
    const AgentTarget& target = options_.targets[static_cast<std::size_t>(next_target_)];
    if ((position_m - target.position_m).norm() > target.radius_m ||
        std::abs(position_m.z() - target.position_m.z()) > target.altitude_band_m)
      break;
    ++next_target_;
  }
  if (next_target_ == n) {
    const bool route_flown = n > 0 && !options_.fly_to_end;
    const double end_s = reference_->plan_end_time_s();
    bool plan_flown = t_s >= end_s;
    if (options_.fly_to_end && plan_flown) {
      // The end position must be reached, not only the plan's time: a UAV held back (a
      // detour, the separation guard) flies on to it, for up to missed_after_s more.
      const Vec3 end = reference_->plan_point(end_s - reference_->delay_target_s()).position_m;
      plan_flown = (position_m - end).norm() <= options_.end_radius_m ||
                   t_s > end_s + options_.missed_after_s;
    }
    if ((route_flown || plan_flown) && !hold_point_threatened(t_s, position_m))
      mode_ = AgentMode::kFinished;
    return;
  }
  if (t_s > reference_->plan_end_time_s() + options_.missed_after_s) {
    for (int k = next_target_; k < n; ++k)
      missed_.push_back(options_.targets[static_cast<std::size_t>(k)].name);
    mode_ = AgentMode::kFinished;
  }
}

bool Agent::hold_point_threatened(double t_s, const Vec3& position_m) const {
  constexpr double kStep = 0.5;  // s; at 8 m/s a threat moves 4 m between checks
  for (const auto& [id, k] : threats_) {
    const world::Threat& th = k.threat;
    const double keep = th.radius_m + limits_.threat_margin_m + options_.detour.clearance_m;
    for (double tau = t_s; tau <= t_s + options_.finish_threat_guard_s; tau += kStep)
      if ((th.centre_at(tau) - position_m).norm() < keep) return true;
  }
  return false;
}

void Agent::reapproach_blocked_target(double t_s) {
  const std::size_t k = static_cast<std::size_t>(next_target_);
  if (k >= options_.targets.size() || reapproaches_[k] >= options_.max_reapproaches) return;
  const double plan_now = t_s - reference_->delay_at(t_s);
  if (plan_now < target_pass_s_[k] + options_.reapproach_after_s) return;
  // The mission's time: the missed-target deadline as it stood before this re-approach.
  if (t_s > reference_->plan_end_time_s() + options_.missed_after_s) return;
  // A racetrack back onto the plan reapproach_lead_s before the pass, turned at half the
  // maximum turn rate; the plan is then flown again from there (the delay makes it so).
  const vehicle::VehicleParams& v = options_.tracker.vehicle;
  const double speed = v.cruise_speed_m_s;
  const double radius = 2.0 * speed / v.max_turn_rate_rad_s(speed);
  const double entry_time = target_pass_s_[k] - options_.reapproach_lead_s;
  const Vec3 position = estimate_ ? Vec3(estimate_->head<3>()) : reference_->at(t_s).position_m;
  const double heading = estimate_ ? (*estimate_)[vehicle::kPsi] : reference_->at(t_s).heading_rad;
  // Only a UAV that has itself gone past the pass turns back; one still short of it (behind
  // its reference after an avoidance) flies on to the target.
  const mpc::ReferencePoint pass = reference_->plan_point(target_pass_s_[k]);
  const Vec2 along(std::cos(pass.heading_rad), std::sin(pass.heading_rad));
  constexpr double kPastBy = 10.0;  // m
  if (along.dot((position - pass.position_m).head<2>()) < kPastBy) return;
  std::optional<mpc::SampledReference> loop =
      plan_reapproach_loop(t_s, position, heading, reference_->plan_point(entry_time), radius,
                           speed, *terrain_, limits_);
  ++reapproaches_[k];
  if (!loop) {
    ++counters_.replan_failures;
    return;
  }
  reapproach_until_s_ = loop->end_time_s();
  reference_->rewind(reapproach_until_s_, entry_time);
  reference_->set_detour(std::move(loop));
  ++counters_.reapproaches;
}

void Agent::replan(double t_s, const Vec3& position_m) {
  last_replan_s_ = t_s;
  replan_requested_ = false;
  reapproach_blocked_target(t_s);
  // Far behind (or off) the reference after an avoidance: re-join the validated path.
  if ((reference_->at(t_s).position_m - position_m).norm() > options_.rejoin_distance_m) {
    // Never re-join past an open target: that would give it up.
    double ahead = 30.0;
    if (static_cast<std::size_t>(next_target_) < target_pass_s_.size())
      ahead = std::clamp(target_pass_s_[static_cast<std::size_t>(next_target_)] -
                             (t_s - reference_->delay_at(t_s)),
                         0.0, ahead);
    reference_->rejoin(t_s, position_m, 120.0, ahead);
    ++counters_.rejoins;
  }
  choose_slot(t_s, position_m);
  threat_buffer_ = known_threats();
  const int yielded = add_neighbour_conflicts(t_s, threat_buffer_);
  if (options_.optimizer_replan && t_s < reference_->plan_end_time_s() - 1.0) {
    // The window starts on the reference being flown (a current detour included) and, as long
    // as windows are as long as detours, ends after any current detour: on the delayed plan.
    planning::LocalReplanProblem p;
    p.terrain = terrain_.get();
    p.reference = reference_.get();
    p.reference_end_time_s = reference_->plan_end_time_s();
    p.start_time_s = t_s;
    p.vehicle = options_.tracker.vehicle;
    p.threats = threat_buffer_;
    p.limits = limits_;
    planning::LocalReplanOptions o = options_.local_replan;
    o.window_s = options_.detour.lookahead_s;
    planning::LocalReplanResult r = planning::replan_locally(p, o);
    // No conflict on the flown reference: keep it, a current detour included (it is what
    // avoids the threat, and it ends on the plan).
    if (r.status == planning::LocalReplanStatus::kNoConflict) return;
    if (r.ok()) {
      reference_->set_detour(std::move(r.reference));
      ++counters_.replans;
      ++counters_.optimizer_replans;
      if (yielded > 0) ++counters_.neighbour_conflicts;
      return;
    }
    ++counters_.optimizer_fallbacks;  // and the geometric detour below
  }
  const DelayedPlan plan(*reference_);
  DetourResult detour = plan_detour(plan, t_s, threat_buffer_, *terrain_, limits_, options_.detour);
  switch (detour.status) {
    case DetourResult::Status::kNoConflict:
      if (t_s >= reapproach_until_s_) reference_->set_detour(std::nullopt);  // a loop stays
      break;
    case DetourResult::Status::kPlanned:
      reference_->set_detour(std::move(detour.reference));
      ++counters_.replans;
      if (yielded > 0) ++counters_.neighbour_conflicts;
      break;
    case DetourResult::Status::kFailed:
      // Keep tracking the plan: the MPC's threat rows still push the UAV away (soft).
      reference_->set_detour(std::nullopt);
      ++counters_.replan_failures;
      break;
  }
}

bool Agent::choose_slot(double t_s, const Vec3& position_m) {
  last_slot_check_s_ = t_s;
  if (options_.max_levels <= 0 && options_.max_delay_s <= 0.0) return false;
  constexpr double kStep = 0.5;  // s; at 20 m/s closing speed, 10 m between checks
  constexpr double kTargetBandMargin = 3.0;  // m of a target's band left for tracking error
  const double spacing = options_.level_spacing_m;
  const double crossing = limits_.separation_m + options_.neighbour_conflict_margin_m;
  const int samples = static_cast<int>(options_.level_lookahead_s / kStep) + 1;
  const vehicle::VehicleParams& v = options_.tracker.vehicle;
  const double climb_rate = 0.9 * v.robust_max_climb_rate_m_s();

  // The neighbours this UAV yields to that can reach its reference's neighbourhood within the
  // look-ahead, at the sample times.
  const double reach = crossing + 2.0 * v.max_speed_m_s() * options_.level_lookahead_s;
  yielded_positions_.clear();
  int yielded = 0;
  for (const auto& [id, n] : neighbours_) {
    if (!yields_to(id, n.prediction())) continue;
    if ((messages::expected_position(n.prediction(), t_s) - position_m).norm() > reach) continue;
    for (int i = 0; i < samples; ++i)
      yielded_positions_.push_back(messages::expected_position(n.prediction(), t_s + i * kStep));
    ++yielded;
  }

  // Candidates: levels nearest the current target first (equal: up, away from the terrain);
  // delays added to the current target delay, shortest first.
  const double level_now = reference_->level_at(t_s);
  const double level_target = reference_->level_target_m();
  levels_.clear();
  for (int k = -options_.max_levels; k <= options_.max_levels; ++k) levels_.push_back(k * spacing);
  std::stable_sort(levels_.begin(), levels_.end(), [&](double a, double b) {
    const double da = std::abs(a - level_target), db = std::abs(b - level_target);
    return da != db ? da < db : a > b;
  });
  delays_.clear();
  for (double d = 0.0; d <= options_.max_delay_s + 1e-9; d += options_.delay_step_s)
    delays_.push_back(d);
  const std::size_t nl = levels_.size(), nd = delays_.size();
  conflict_time_.assign(nl * nd, std::numeric_limits<double>::infinity());
  feasible_.assign(nl * nd, 1);
  const double delay_now = reference_->delay_at(t_s);
  const double delay_target = reference_->delay_target_s();
  const double rate = delay_target > delay_now ? reference_->delay_rate() : options_.delay_rate;
  bool any_conflict = false;
  const auto level_of = [&](double level, double tau) {
    const double moved = climb_rate * (tau - t_s), gap = level - level_now;
    return std::abs(gap) <= moved ? level : level_now + std::copysign(moved, gap);
  };

  for (std::size_t d = 0; d < nd; ++d) {
    const double target = delay_target + delays_[d];
    for (int i = 0; i < samples; ++i) {
      const double tau = t_s + i * kStep;
      const double delay = std::min(target, delay_now + rate * (tau - t_s));
      const Vec3 r = reference_->plan_point(tau - delay).position_m;
      const double ground = terrain_->height(r.x(), r.y());
      for (std::size_t c = 0; c < nl; ++c) {
        const double z = r.z() + level_of(levels_[c], tau);
        const bool ok = z >= ground + limits_.terrain_clearance_m + options_.level_terrain_margin_m &&
                        z >= limits_.altitude.min_m + options_.level_terrain_margin_m &&
                        z <= limits_.altitude.max_m - options_.level_terrain_margin_m;
        if (!ok) feasible_[d * nl + c] = 0;
      }
      // A target is inspected inside its altitude band: a level must not lift the UAV out.
      // (Whether the sample is over a target does not depend on the level: tested once.)
      for (std::size_t k = static_cast<std::size_t>(next_target_); k < options_.targets.size(); ++k) {
        const AgentTarget& target_k = options_.targets[k];
        if ((r.head<2>() - target_k.position_m.head<2>()).norm() > target_k.radius_m) continue;
        const double band = std::max(0.0, target_k.altitude_band_m - kTargetBandMargin);
        for (std::size_t c = 0; c < nl; ++c) {
          const double z = r.z() + level_of(levels_[c], tau);
          if (std::abs(z - target_k.position_m.z()) > band) feasible_[d * nl + c] = 0;
        }
      }
      for (int k = 0; k < yielded; ++k) {
        const Vec3& q = yielded_positions_[static_cast<std::size_t>(k * samples + i)];
        if ((q.head<2>() - r.head<2>()).norm() >= crossing) continue;
        if (d == 0) any_conflict = true;
        for (std::size_t c = 0; c < nl; ++c) {
          double& first = conflict_time_[d * nl + c];
          if (tau < first && std::abs(r.z() + level_of(levels_[c], tau) - q.z()) < spacing - 1.0)
            first = tau;
        }
      }
    }
    // With no crossing at the current delay the choice reads only the current delay's slots
    // (below): the later delays are not searched.
    if (d == 0 && !any_conflict) break;
  }

  // The choice: with no crossing at the current delay, back to the plan's altitude. Otherwise
  // keep the slot being flown to while it stays free (a slot that changes at every re-plan is
  // one the others cannot plan around); else the cheapest free slot; else, when none is free
  // (a conflict already too close for any slot), the one whose first conflict comes latest.
  std::size_t best = nl * nd;
  const auto cost = [&](std::size_t k) {
    return std::abs(levels_[k % nl] - level_target) / spacing +
           delays_[k / nl] / options_.delay_per_level_s;
  };
  const std::size_t keep = 0;  // levels_[0] is the target level, delays_[0] adds nothing
  if (!any_conflict) {
    const auto zero = std::find(levels_.begin(), levels_.end(), 0.0);
    const std::size_t k = static_cast<std::size_t>(zero - levels_.begin());
    best = feasible_[k] ? k : keep;
  } else if (feasible_[keep] && std::isinf(conflict_time_[keep])) {
    best = keep;
  } else {
    for (std::size_t k = 0; k < nl * nd; ++k) {
      if (!feasible_[k]) continue;
      if (best == nl * nd) {
        best = k;
        continue;
      }
      const double tk = conflict_time_[k], tb = conflict_time_[best];
      if (tk > tb || (tk == tb && cost(k) < cost(best))) best = k;
    }
    if (best == nl * nd) best = keep;  // no feasible slot: nothing better than the current one
  }
  const double level = levels_[best % nl];
  const double added_delay = delays_[best / nl];
  if (level != level_target) {
    reference_->set_level(t_s, level, climb_rate);
    ++counters_.level_changes;
  }
  if (added_delay > 0.0) {
    reference_->set_delay(t_s, delay_target + added_delay, rate);
    ++counters_.delay_changes;
  }
  return level != level_target || added_delay > 0.0;
}

void Agent::update_intent(double t_s) {
  if (reference_->revision() == intent_revision_ &&
      t_s < intent_start_s_ + options_.intent_step_s)
    return;
  intent_revision_ = reference_->revision();
  intent_start_s_ = t_s;
  const int count = static_cast<int>(options_.level_lookahead_s / options_.intent_step_s) + 2;
  intent_.resize(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k)
    intent_[static_cast<std::size_t>(k)] = reference_->at(t_s + k * options_.intent_step_s).position_m;
}

int Agent::add_neighbour_conflicts(double t_s, std::vector<world::Threat>& obstacles) const {
  const double d_safe = limits_.separation_m;
  const double conflict_distance = d_safe + options_.neighbour_conflict_margin_m;
  const double horizon = options_.neighbour_lookahead_s;
  constexpr double kCheckStep = 0.25;   // s; at 20 m/s closing speed, 5 m between checks
  int added = 0;
  for (const auto& [id, n] : neighbours_) {
    const PredictedTrajectory& nb = n.prediction();
    const int count = static_cast<int>(nb.positions_m.size());
    // Mean velocity over the broadcast horizon: extrapolating the last segment alone would
    // magnify the end of a turn.
    const Vec3 velocity = count >= 2 ? Vec3((nb.positions_m.back() - nb.positions_m.front()) /
                                            (nb.step_s * (count - 1)))
                                     : Vec3::Zero();
    const auto neighbour_at = [&](double t) { return messages::expected_position(nb, t); };
    if (!yields_to(id, nb)) continue;  // the other one yields
    // Out of reach over the look-ahead (the reference and the neighbour closing at full
    // speed): no conflict, and no sampling, which is what made large teams slow.
    const double closing_m_s = options_.tracker.vehicle.max_speed_m_s() +
                               std::max(options_.tracker.vehicle.max_speed_m_s(), velocity.norm());
    if ((neighbour_at(t_s) - reference_->at(t_s).position_m).norm() >
        conflict_distance + closing_m_s * horizon)
      continue;
    bool conflict = false;
    for (double tau = t_s; tau <= t_s + horizon && !conflict; tau += kCheckStep) {
      const Vec3 gap = neighbour_at(tau) - reference_->at(tau).position_m;
      // A crossing a level apart is resolved vertically (choose_level).
      conflict = gap.head<2>().norm() < conflict_distance &&
                 std::abs(gap.z()) < options_.level_spacing_m - 1.0;
    }
    if (!conflict) continue;
    world::Threat obstacle;
    obstacle.name = fmt::format("uav{}", id);
    obstacle.centre_m = neighbour_at(t_s);
    obstacle.velocity_m_s = velocity;
    obstacle.radius_m = d_safe;
    obstacle.appear_s = t_s;
    obstacle.vanish_s = t_s + horizon;
    obstacles.push_back(std::move(obstacle));
    ++added;
  }
  return added;
}

bool Agent::yields_to(int neighbour, const PredictedTrajectory& prediction) const {
  if (neighbour < options_.id) return true;
  // A (nearly) stationary neighbour, e.g. finished and holding, cannot give way.
  const std::size_t n = prediction.positions_m.size();
  if (n < 2) return true;
  constexpr double kStationary = 0.5;  // m/s
  const double span_s = prediction.step_s * static_cast<double>(n - 1);
  return (prediction.positions_m.back() - prediction.positions_m.front()).norm() <
         kStationary * span_s;
}

double mpc_neighbour_reach_m(const AgentOptions& options, const world::SafetyLimits& limits) {
  const mpc::UavTrackerOptions& t = options.tracker;
  return 2.0 * t.vehicle.max_speed_m_s() * t.prediction_step_s * t.prediction_horizon +
         limits.separation_m + options.separation_margin_m + options.max_age_margin_m +
         t.activation_distance_m;
}

void Agent::select_neighbours(double t_s, const Vec3& position_m) {
  const mpc::UavTrackerOptions& tracker = options_.tracker;
  const double v_max = tracker.vehicle.max_speed_m_s();
  const double d_safe = limits_.separation_m;
  const double reach = mpc_neighbour_reach_m(options_, limits_);
  nearby_.clear();
  bool stale = false;
  for (const auto& [id, n] : neighbours_) {
    const double age = std::max(0.0, t_s - n.prediction().stamp_s);
    stale = stale || age > options_.neighbour_stale_s;
    const double distance = (messages::predicted_position(n.prediction(), t_s) - position_m).norm();
    if (distance <= reach + v_max * age) nearby_.push_back({distance, id});
  }
  counters_.stale_neighbour_steps += stale ? 1 : 0;
  std::sort(nearby_.begin(), nearby_.end());
  const std::size_t count =
      std::min<std::size_t>(nearby_.size(), static_cast<std::size_t>(tracker.max_neighbours));
  guard_neighbours_.resize(nearby_.size());
  guard_yields_to_me_.resize(nearby_.size());
  for (std::size_t k = 0; k < nearby_.size(); ++k) {
    const int id = nearby_[k].second;
    guard_neighbours_[k] = &neighbours_.at(id).prediction();
    guard_yields_to_me_[k] = yields_to(id, *guard_neighbours_[k]) ? 0 : 1;
  }
  neighbour_buffer_.resize(count);
  neighbour_separation_.resize(count);
  // The MPC's neighbours: the nearest of the guard's, with the same yielding.
  for (std::size_t k = 0; k < count; ++k) {
    const PredictedTrajectory& p = *guard_neighbours_[k];
    neighbour_buffer_[k] = p;  // reuses the element's capacity
    const double age = std::max(0.0, t_s - p.stamp_s);
    neighbour_separation_[k] =
        guard_yields_to_me_[k] == 0
            ? d_safe + options_.separation_margin_m +
                  std::min(options_.age_margin_m_s * age, options_.max_age_margin_m)
            : d_safe;
  }
}

vehicle::Input Agent::fallback_command(double t_s, const vehicle::State& state) const {
  const vehicle::VehicleParams& p = options_.tracker.vehicle;
  const Vec3 to_ref = reference_->at(t_s).position_m - state.head<3>();
  const double bearing = std::atan2(to_ref.y(), to_ref.x());
  const double v = std::max(state[vehicle::kV], p.min_speed_m_s());
  const double heading_error = wrap_angle(bearing - state[vehicle::kPsi]);
  const double z = state[vehicle::kZ];
  const double clearance = z - terrain_->height(state[vehicle::kX], state[vehicle::kY]);
  double climb = 0.0;
  if (clearance < 2.0 * limits_.terrain_clearance_m) climb = p.max_climb_rate_m_s;
  if (z > limits_.altitude.max_m - 10.0) climb = -0.5 * p.max_climb_rate_m_s;
  vehicle::Input u(p.min_speed_m_s(), 0.5 * heading_error, climb);
  u[1] = std::clamp(u[1], -p.max_turn_rate_rad_s(v), p.max_turn_rate_rad_s(v));
  return rate_limited(u, state);
}

vehicle::Input Agent::rate_limited(const vehicle::Input& target,
                                   const vehicle::State& state) const {
  // Rate limits of one control period, as the tracker obeys them.
  const Vec3 step_max = command_rate_ * options_.tracker.control_period_s;
  vehicle::Input u = target;
  for (int k = 0; k < 3; ++k)
    u[k] = std::clamp(u[k], last_command_[k] - step_max[k], last_command_[k] + step_max[k]);
  // The climb bound that keeps the pitch limit while the speed falls, as the tracker's.
  const double climb = options_.tracker.vehicle.robust_max_climb_rate_m_s();
  u[2] = std::clamp(u[2], -climb, climb);
  return vehicle::clamp_to_limits(u, state, options_.tracker.vehicle);
}

vehicle::Input Agent::guard_command(double t_s, const vehicle::State& state,
                                    const vehicle::Input& planned,
                                    const mpc::UavTrackerResult& r, FlownPath& path) {
  const SeparationGuardOptions& g = guard_.options();
  GuardInput in;
  in.t_s = t_s;
  in.state = state;
  in.last_command = last_command_;
  in.planned_command = planned;
  in.wind_m_s = wind_estimate_;
  if (mode_ == AgentMode::kFallback) {
    // The fallback's command held: what it will fly, and what the neighbours should see.
    vehicle::rollout_positions(state, last_command_, planned, command_rate_, wind_estimate_,
                               options_.tracker.vehicle, g.step_s,
                               std::max(1, static_cast<int>(std::round(g.horizon_s / g.step_s))),
                               planned_path_);
    in.planned_start_s = t_s + g.step_s;
    in.planned_step_s = g.step_s;
  } else {
    planned_path_.resize(static_cast<std::size_t>(r.predicted_positions_m.cols()));
    for (Eigen::Index j = 0; j < r.predicted_positions_m.cols(); ++j)
      planned_path_[static_cast<std::size_t>(j)] = r.predicted_positions_m.col(j);
    in.planned_start_s = r.first_prediction_time_s;
    in.planned_step_s = r.prediction_step_s;
  }
  in.planned_path_m = planned_path_;
  path = FlownPath{&planned_path_, in.planned_start_s, in.planned_step_s};
  const GuardSurroundings around{guard_neighbours_, guard_yields_to_me_, threat_buffer_,
                                 terrain_.get(), &limits_};
  const GuardDecision d = guard_.check(in, around);
  if (!d.escape) return planned;
  ++counters_.guard_steps;
  path = FlownPath{&guard_.escape_path(), t_s + g.step_s, g.step_s};
  const vehicle::Input u = rate_limited(d.command, state);
  if (mode_ == AgentMode::kTracking) tracker_.record_applied_command(u);
  return u;
}

AgentStep Agent::control(double t_s, const vehicle::State& measured,
                         const Vec3& measured_wind_m_s) {
  AgentStep out;
  if (estimate_ && t_s > estimate_time_s_) {
    const double dt = t_s - estimate_time_s_;
    wind_estimate_ += dt / (options_.wind_filter_time_s + dt) * (measured_wind_m_s - wind_estimate_);
    const vehicle::State predicted = vehicle::euler_step(*estimate_, last_command_, wind_estimate_,
                                                         options_.tracker.vehicle,
                                                         t_s - estimate_time_s_);
    const Vec3 innovation = measured.head<3>() - predicted.head<3>();
    vehicle::State e = measured;
    // A fix far from the prediction means the estimate, not the fix, is wrong (a hold, a
    // restart): start again from the fix.
    if (innovation.norm() <= options_.position_reset_m)
      e.head<3>() = predicted.head<3>() + options_.position_filter_gain * innovation;
    estimate_ = e;
  } else {
    estimate_ = measured;
    wind_estimate_ = measured_wind_m_s;
  }
  estimate_time_s_ = t_s;
  const vehicle::State& measured_state = *estimate_;
  const Vec3 position = measured_state.head<3>();
  if (mode_ != AgentMode::kFinished) update_mission(t_s, position);
  if (mode_ == AgentMode::kFinished) {
    out.mode = mode_;
    out.command = vehicle::Input::Zero();
    out.reference_m = position;
    prediction_ = std::make_shared<const Message>(
        PredictedTrajectory{options_.id, t_s, options_.tracker.prediction_step_s,
                            std::vector<Vec3>(options_.tracker.prediction_horizon, position)});
    return out;
  }
  forget_old_threats(t_s);
  if (neighbour_replan_requested_ && t_s - last_slot_check_s_ >= options_.min_replan_interval_s) {
    // Only a slot that has to change re-plans early: the detour is refreshed periodically.
    neighbour_replan_requested_ = false;
    if (choose_slot(t_s, position)) replan_requested_ = true;
  }
  if (replan_requested_ || t_s - last_replan_s_ >= options_.replan_period_s) replan(t_s, position);

  threat_buffer_ = known_threats();
  select_neighbours(t_s, position);
  const mpc::TrackerEnvironment environment{threat_buffer_, neighbour_buffer_, terrain_.get(),
                                            neighbour_separation_};

  if (mode_ == AgentMode::kFallback) tracker_.reset(last_command_);
  const mpc::UavTrackerResult& r =
      tracker_.step(t_s, measured_state, wind_estimate_, *reference_, environment);
  const bool solved = r.qp_status == qp::QpStatus::kSolved;
  if (!solved) ++counters_.qp_failures;
  consecutive_failures_ = solved ? 0 : consecutive_failures_ + 1;
  consecutive_successes_ = solved ? consecutive_successes_ + 1 : 0;

  const Vec3 reference_position = reference_->at(t_s).position_m;
  const bool lost = (reference_position - position).norm() > options_.lost_reference_m;
  if (mode_ == AgentMode::kTracking &&
      (consecutive_failures_ >= options_.fallback_after_failures || lost)) {
    mode_ = AgentMode::kFallback;
  } else if (mode_ == AgentMode::kFallback && !lost &&
             consecutive_successes_ >= options_.recover_after_successes) {
    mode_ = AgentMode::kTracking;
  }

  vehicle::Input planned = r.command;
  if (mode_ == AgentMode::kFallback) {
    planned = fallback_command(t_s, measured_state);
    ++counters_.fallback_steps;
  }
  FlownPath flown;
  out.command = guard_command(t_s, measured_state, planned, r, flown);
  last_command_ = out.command;
  out.mode = mode_;
  out.reference_m = reference_position;
  out.tracker = &r;
  out.max_slack_m = r.max_slack_m();

  if (!flown.positions->empty()) {
    // Broadcast what will be flown, stamped with the time it starts from.
    PredictedTrajectory p;
    p.uav = options_.id;
    p.step_s = flown.step_s;
    p.stamp_s = flown.first_time_s - flown.step_s;
    p.positions_m = *flown.positions;
    update_intent(t_s);
    p.intent_start_s = intent_start_s_;
    p.intent_step_s = options_.intent_step_s;
    p.intent_m = intent_;
    p.intent_revision = intent_revision_;
    prediction_ = std::make_shared<const Message>(std::move(p));
  }
  return out;
}

}  // namespace ridgeline::swarm
