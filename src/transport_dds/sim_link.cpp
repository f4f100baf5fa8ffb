#include "transport_dds/sim_link.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>

#include "core/error.hpp"
#include "transport_dds/dds_support.hpp"
#include "transport_dds/ridgeline_msgs.h"

namespace ridgeline::transport_dds {
namespace {

using V3 = ridgeline_msg_dds__Vector3_;
V3 to_dds(const Vec3& v) { return V3{v.x(), v.y(), v.z()}; }
Vec3 from_dds(const V3& v) { return Vec3(v.x, v.y, v.z); }

constexpr std::uint32_t kMaxThreats = 1000;
constexpr std::uint32_t kMaxLost = 1000;
constexpr std::uint32_t kMaxMissed = 1000;
constexpr int kNumCounters = 12;
// The IDL's counters[] carries every field of AgentCounters, in declaration order.
static_assert(sizeof(swarm::AgentCounters) == kNumCounters * sizeof(std::uint64_t),
              "AgentCounters and Command_::counters (ridgeline_msgs.idl) must match");

std::optional<std::string> check_uav(int uav, int num_uavs) {
  if (uav < 0 || uav >= num_uavs)
    return fmt::format("uav {} is not a UAV of this team (0..{})", uav, num_uavs - 1);
  return std::nullopt;
}

std::array<std::uint64_t*, kNumCounters> counter_fields(swarm::AgentCounters& c) {
  return {&c.messages_received, &c.messages_rejected,   &c.stale_neighbour_steps,
          &c.replans,           &c.neighbour_conflicts, &c.replan_failures,
          &c.optimizer_replans, &c.optimizer_fallbacks, &c.rejoins,
          &c.fallback_steps,    &c.qp_failures,         &c.threat_reports_sent};
}

}  // namespace

SimLinkRole world_role() {
  SimLinkRole r;
  r.publishes_clock = r.publishes_measurements = r.reads_commands = true;
  return r;
}
SimLinkRole agent_role() {
  SimLinkRole r;
  r.publishes_commands = r.reads_clock = r.reads_measurements = true;
  return r;
}
SimLinkRole observer_role() {
  SimLinkRole r;
  r.reads_clock = r.reads_measurements = r.reads_commands = true;
  return r;
}

std::optional<std::string> check_measurement(const Measurement& m, int num_uavs) {
  if (auto e = check_uav(m.uav, num_uavs)) return e;
  if (!(std::isfinite(m.t_s) && m.t_s >= 0.0)) return fmt::format("t_s {} is invalid", m.t_s);
  if (!m.state.allFinite()) return std::string("state is not finite");
  if (!m.wind_m_s.allFinite()) return std::string("wind is not finite");
  if (m.threats.size() > kMaxThreats)
    return fmt::format("{} threats, at most {}", m.threats.size(), kMaxThreats);
  for (const swarm::ThreatObservation& o : m.threats) {
    if (o.threat_id < 0) return fmt::format("threat id {} is negative", o.threat_id);
    if (!o.centre_m.allFinite() || !o.velocity_m_s.allFinite())
      return std::string("a threat's centre or velocity is not finite");
    if (!(std::isfinite(o.radius_m) && o.radius_m > 0.0))
      return fmt::format("threat radius {} m is invalid", o.radius_m);
  }
  return std::nullopt;
}

std::optional<std::string> check_command(const CommandReport& c, int num_uavs) {
  if (auto e = check_uav(c.uav, num_uavs)) return e;
  if (c.hello) return std::nullopt;
  if (!(std::isfinite(c.t_s) && c.t_s >= 0.0)) return fmt::format("t_s {} is invalid", c.t_s);
  if (!c.command.allFinite()) return std::string("command is not finite");
  if (!c.reference_m.allFinite()) return std::string("reference is not finite");
  for (const double v : {c.mpc_step_us, c.mpc_step_cpu_us, c.qp_iterations, c.max_slack_m,
                         c.loop_period_s, c.compute_s})
    if (!(std::isfinite(v) && v >= 0.0)) return fmt::format("a timing or count {} is invalid", v);
  if (c.targets_inspected < 0 || c.targets_assigned < 0 || c.targets_inspected > c.targets_assigned)
    return fmt::format("targets inspected {} of {} is invalid", c.targets_inspected,
                       c.targets_assigned);
  if (c.missed_targets.size() > kMaxMissed) return std::string("too many missed targets");
  return std::nullopt;
}

struct SimLink::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t clock_writer = 0, clock_reader = 0;
  dds_entity_t measurement_writer = 0, measurement_reader = 0;
  dds_entity_t command_writer = 0, command_reader = 0;
  dds_entity_t waitset = 0;
  std::vector<ridgeline_msg_dds__SensedThreat_> threats;
  std::vector<std::int32_t> ids, answered;
  std::vector<std::int64_t> reports;
  std::vector<double> stamps;
  std::vector<char*> names;
};

SimLink::SimLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, const SimLinkRole& role)
    : impl_(std::make_unique<Impl>()), num_uavs_(num_uavs) {
  if (participant == nullptr) throw InputError("participant", "is required");
  if (num_uavs < 1) throw InputError("num_uavs", "must be at least 1");
  Impl& d = *impl_;
  d.participant = std::move(participant);
  const dds_entity_t p = d.participant->handle();
  const std::string& part = d.participant->partition();
  const dds_entity_t clock = make_topic(p, &ridgeline_msg_dds__Clock__desc, "rt/ridgeline/clock");
  const dds_entity_t measurement =
      make_topic(p, &ridgeline_msg_dds__Measurement__desc, "rt/ridgeline/measurement");
  const dds_entity_t command =
      make_topic(p, &ridgeline_msg_dds__Command__desc, "rt/ridgeline/command");
  if (role.publishes_clock) d.clock_writer = make_writer(p, clock, TopicQos::kReliable, 8, part);
  if (role.publishes_measurements)
    d.measurement_writer = make_writer(p, measurement, TopicQos::kReliable, 4, part);
  if (role.publishes_commands)
    d.command_writer = make_writer(p, command, TopicQos::kReliable, 4, part);
  d.waitset = dds_check(dds_create_waitset(p), "dds_create_waitset");
  auto reader = [&](dds_entity_t topic, int depth) {
    const dds_entity_t r = make_reader(p, topic, TopicQos::kReliable, depth, part);
    const dds_entity_t condition =
        dds_check(dds_create_readcondition(r, DDS_ANY_STATE), "dds_create_readcondition");
    dds_check(dds_waitset_attach(d.waitset, condition, r), "dds_waitset_attach");
    return r;
  };
  if (role.reads_clock) d.clock_reader = reader(clock, 8);
  if (role.reads_measurements) d.measurement_reader = reader(measurement, 4);
  if (role.reads_commands) d.command_reader = reader(command, 4);
}

SimLink::~SimLink() {
  const Impl& d = *impl_;
  dds_delete(d.waitset);
  for (const dds_entity_t e : {d.clock_writer, d.clock_reader, d.measurement_writer,
                               d.measurement_reader, d.command_writer, d.command_reader})
    if (e > 0) dds_delete(e);
}

void SimLink::publish(const ClockTick& clock) {
  Impl& d = *impl_;
  if (d.clock_writer == 0) throw InputError("SimLink", "this role does not publish the clock");
  d.ids.assign(clock.lost.begin(), clock.lost.end());
  ridgeline_msg_dds__Clock_ s{};
  s.tick = clock.tick;
  s.t_s = clock.t_s;
  s.running = clock.running;
  s.lock_step = clock.lock_step;
  s.lost._maximum = s.lost._length = static_cast<std::uint32_t>(d.ids.size());
  s.lost._buffer = d.ids.data();
  s.lost._release = false;
  if (clock.answered.size() != clock.reports_sent.size() ||
      clock.answered.size() != clock.prediction_stamps.size())
    throw InputError("ClockTick", "answered, reports_sent and prediction_stamps differ in length");
  d.answered.assign(clock.answered.begin(), clock.answered.end());
  d.reports.assign(clock.reports_sent.begin(), clock.reports_sent.end());
  s.answered._maximum = s.answered._length = static_cast<std::uint32_t>(d.answered.size());
  s.answered._buffer = d.answered.data();
  s.answered._release = false;
  s.reports_sent._maximum = s.reports_sent._length = static_cast<std::uint32_t>(d.reports.size());
  s.reports_sent._buffer = d.reports.data();
  s.reports_sent._release = false;
  d.stamps.assign(clock.prediction_stamps.begin(), clock.prediction_stamps.end());
  s.prediction_stamps._maximum = s.prediction_stamps._length =
      static_cast<std::uint32_t>(d.stamps.size());
  s.prediction_stamps._buffer = d.stamps.data();
  s.prediction_stamps._release = false;
  dds_check(dds_write(d.clock_writer, &s), "dds_write(clock)");
  ++stats_.published;
}

void SimLink::publish(const Measurement& m) {
  Impl& d = *impl_;
  if (d.measurement_writer == 0)
    throw InputError("SimLink", "this role does not publish measurements");
  d.threats.clear();
  for (const swarm::ThreatObservation& o : m.threats)
    d.threats.push_back({o.threat_id, to_dds(o.centre_m), to_dds(o.velocity_m_s), o.radius_m});
  ridgeline_msg_dds__Measurement_ s{};
  s.uav = m.uav;
  s.tick = m.tick;
  s.t_s = m.t_s;
  for (int k = 0; k < 7; ++k) s.s[k] = m.state[k];
  s.wind_m_s = to_dds(m.wind_m_s);
  s.threats._maximum = s.threats._length = static_cast<std::uint32_t>(d.threats.size());
  s.threats._buffer = d.threats.data();
  s.threats._release = false;
  dds_check(dds_write(d.measurement_writer, &s), "dds_write(measurement)");
  ++stats_.published;
}

void SimLink::publish(const CommandReport& c) {
  Impl& d = *impl_;
  if (d.command_writer == 0) throw InputError("SimLink", "this role does not publish commands");
  d.names.clear();
  for (const std::string& name : c.missed_targets)
    d.names.push_back(const_cast<char*>(name.c_str()));
  ridgeline_msg_dds__Command_ s{};
  s.uav = c.uav;
  s.hello = c.hello;
  s.tick = c.tick;
  s.t_s = c.t_s;
  for (int k = 0; k < 3; ++k) s.u[k] = c.command[k];
  s.mode = static_cast<std::int32_t>(c.mode);
  s.reference_m = to_dds(c.reference_m);
  s.has_tracker = c.has_tracker;
  s.mpc_step_us = c.mpc_step_us;
  s.mpc_step_cpu_us = c.mpc_step_cpu_us;
  s.qp_iterations = c.qp_iterations;
  s.max_slack_m = c.max_slack_m;
  s.plan_version = c.plan_version;
  s.targets_assigned = c.targets_assigned;
  s.targets_inspected = c.targets_inspected;
  s.missed_targets._maximum = s.missed_targets._length = static_cast<std::uint32_t>(d.names.size());
  s.missed_targets._buffer = d.names.data();
  s.missed_targets._release = false;
  swarm::AgentCounters counters = c.counters;
  const auto fields = counter_fields(counters);
  for (int k = 0; k < kNumCounters; ++k) s.counters[k] = static_cast<std::int64_t>(*fields[k]);
  s.prediction_stamp_s = c.prediction_stamp_s;
  s.loop_period_s = c.loop_period_s;
  s.compute_s = c.compute_s;
  dds_check(dds_write(d.command_writer, &s), "dds_write(command)");
  ++stats_.published;
}

void SimLink::take(std::vector<ClockTick>& out) {
  if (impl_->clock_reader == 0) return;
  take_all<ridgeline_msg_dds__Clock_>(impl_->clock_reader, [&](const auto& s) {
    ++stats_.received;
    ClockTick c;
    c.tick = s.tick;
    c.t_s = s.t_s;
    c.running = s.running;
    c.lock_step = s.lock_step;
    std::string reason;
    if (!(std::isfinite(s.t_s) && s.t_s >= 0.0)) reason = fmt::format("t_s {} is invalid", s.t_s);
    if (s.lost._length > kMaxLost || s.answered._length > kMaxLost)
      reason =
          fmt::format("{} lost and {} answered UAVs, too many", s.lost._length, s.answered._length);
    if (s.answered._length != s.reports_sent._length ||
        s.answered._length != s.prediction_stamps._length)
      reason = "answered, reports_sent and prediction_stamps differ in length";
    if (reason.empty()) {
      for (std::uint32_t k = 0; k < s.lost._length; ++k) {
        if (auto e = check_uav(s.lost._buffer[k], num_uavs_)) reason = *e;
        c.lost.push_back(s.lost._buffer[k]);
      }
      for (std::uint32_t k = 0; k < s.answered._length; ++k) {
        if (auto e = check_uav(s.answered._buffer[k], num_uavs_)) reason = *e;
        if (s.reports_sent._buffer[k] < 0) reason = "a report count is negative";
        c.answered.push_back(s.answered._buffer[k]);
        c.reports_sent.push_back(s.reports_sent._buffer[k]);
        c.prediction_stamps.push_back(s.prediction_stamps._buffer[k]);
        if (!std::isfinite(s.prediction_stamps._buffer[k])) reason = "a stamp is not finite";
      }
    }
    if (!reason.empty()) {
      ++stats_.rejected;
      stats_.last_rejection = "Clock: " + reason;
      return;
    }
    out.push_back(std::move(c));
  });
}

void SimLink::take(std::vector<Measurement>& out, int uav) {
  if (impl_->measurement_reader == 0) return;
  take_all<ridgeline_msg_dds__Measurement_>(impl_->measurement_reader, [&](const auto& s) {
    if (uav >= 0 && s.uav != uav) return;
    ++stats_.received;
    Measurement m;
    m.uav = s.uav;
    m.tick = s.tick;
    m.t_s = s.t_s;
    for (int k = 0; k < 7; ++k) m.state[k] = s.s[k];
    m.wind_m_s = from_dds(s.wind_m_s);
    if (s.threats._length > kMaxThreats) {
      ++stats_.rejected;
      stats_.last_rejection = fmt::format("Measurement: {} threats, too many", s.threats._length);
      return;
    }
    for (std::uint32_t k = 0; k < s.threats._length; ++k) {
      const ridgeline_msg_dds__SensedThreat_& o = s.threats._buffer[k];
      m.threats.push_back(
          {o.threat_id, from_dds(o.centre_m), from_dds(o.velocity_m_s), o.radius_m});
    }
    if (auto reason = check_measurement(m, num_uavs_)) {
      ++stats_.rejected;
      stats_.last_rejection = "Measurement: " + *reason;
      return;
    }
    out.push_back(std::move(m));
  });
}

void SimLink::take(std::vector<CommandReport>& out) {
  if (impl_->command_reader == 0) return;
  take_all<ridgeline_msg_dds__Command_>(impl_->command_reader, [&](const auto& s) {
    ++stats_.received;
    CommandReport c;
    c.uav = s.uav;
    c.hello = s.hello;
    c.tick = s.tick;
    c.t_s = s.t_s;
    c.command = vehicle::Input(s.u[0], s.u[1], s.u[2]);
    c.reference_m = from_dds(s.reference_m);
    c.has_tracker = s.has_tracker;
    c.mpc_step_us = s.mpc_step_us;
    c.mpc_step_cpu_us = s.mpc_step_cpu_us;
    c.qp_iterations = s.qp_iterations;
    c.max_slack_m = s.max_slack_m;
    c.plan_version = s.plan_version;
    c.targets_assigned = s.targets_assigned;
    c.targets_inspected = s.targets_inspected;
    c.prediction_stamp_s = s.prediction_stamp_s;
    c.loop_period_s = s.loop_period_s;
    c.compute_s = s.compute_s;
    std::string reason;
    if (s.mode < 0 || s.mode > 2) reason = fmt::format("mode {} is not an agent mode", s.mode);
    if (s.missed_targets._length > kMaxMissed) reason = "too many missed targets";
    for (int k = 0; k < kNumCounters && reason.empty(); ++k)
      if (s.counters[k] < 0) reason = fmt::format("counter {} is negative", k);
    if (reason.empty()) {
      c.mode = static_cast<swarm::AgentMode>(s.mode);
      for (std::uint32_t k = 0; k < s.missed_targets._length; ++k)
        c.missed_targets.emplace_back(s.missed_targets._buffer[k] ? s.missed_targets._buffer[k]
                                                                  : "");
      const auto fields = counter_fields(c.counters);
      for (int k = 0; k < kNumCounters; ++k) *fields[k] = static_cast<std::uint64_t>(s.counters[k]);
      if (auto e = check_command(c, num_uavs_)) reason = *e;
    }
    if (!reason.empty()) {
      ++stats_.rejected;
      stats_.last_rejection = "Command: " + reason;
      return;
    }
    out.push_back(std::move(c));
  });
}

bool SimLink::wait(double timeout_s) {
  const dds_duration_t timeout =
      timeout_s <= 0.0 ? 0 : static_cast<dds_duration_t>(timeout_s * 1e9);
  const dds_return_t n = dds_waitset_wait(impl_->waitset, nullptr, 0, timeout);
  return n > 0;
}

namespace {
int matched_readers(dds_entity_t writer) {
  if (writer == 0) return 0;
  dds_publication_matched_status_t status;
  if (dds_get_publication_matched_status(writer, &status) < 0) return 0;
  return static_cast<int>(status.current_count);
}
}  // namespace

int SimLink::matched_measurement_readers() const {
  return matched_readers(impl_->measurement_writer);
}
int SimLink::matched_command_readers() const { return matched_readers(impl_->command_writer); }

}  // namespace ridgeline::transport_dds
