#include "transport_dds/sim_link.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"
#include "transport_dds/wire_types.hpp"

namespace ridgeline::transport_dds {
namespace {

// Sequences of a clock, a measurement or a command (lost and answered UAVs, threats in sight,
// missed targets) are bounded by this many before anything is allocated for them.
constexpr std::uint32_t kMaxSequence = 1000;

std::optional<std::string> check_uav(int uav, int num_uavs) {
  if (uav < 0 || uav >= num_uavs)
    return fmt::format("uav {} is not a UAV of this team (0..{})", uav, num_uavs - 1);
  return std::nullopt;
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
  if (m.threats.size() > kMaxSequence)
    return fmt::format("{} threats, at most {}", m.threats.size(), kMaxSequence);
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
  if (c.mode != swarm::AgentMode::kTracking && c.mode != swarm::AgentMode::kFallback &&
      c.mode != swarm::AgentMode::kFinished)
    return fmt::format("mode {} is not an agent mode", static_cast<int>(c.mode));
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
  if (c.missed_targets.size() > kMaxSequence) return std::string("too many missed targets");
  return std::nullopt;
}

struct SimLink::Impl {
  std::shared_ptr<DdsParticipant> participant;
  dds_entity_t clock_writer = 0, clock_reader = 0;
  dds_entity_t measurement_writer = 0, measurement_reader = 0;
  dds_entity_t command_writer = 0, command_reader = 0;
  dds_entity_t waitset = 0;
  WireArena arena;
};

SimLink::SimLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, const SimLinkRole& role)
    : impl_(std::make_unique<Impl>()), num_uavs_(num_uavs) {
  if (participant == nullptr) throw InputError("participant", "is required");
  if (num_uavs < 1) throw InputError("num_uavs", "must be at least 1");
  Impl& d = *impl_;
  d.participant = std::move(participant);
  const dds_entity_t p = d.participant->handle();
  const std::string& part = d.participant->partition();
  const dds_entity_t clock = make_topic_of<ClockTick>(p);
  const dds_entity_t measurement = make_topic_of<Measurement>(p);
  const dds_entity_t command = make_topic_of<CommandReport>(p);
  if (role.publishes_clock) d.clock_writer = make_writer_of<ClockTick>(p, clock, part);
  if (role.publishes_measurements)
    d.measurement_writer = make_writer_of<Measurement>(p, measurement, part);
  if (role.publishes_commands) d.command_writer = make_writer_of<CommandReport>(p, command, part);
  d.waitset = dds_check(dds_create_waitset(p), "dds_create_waitset");
  auto reader = [&]<class M>(M*, dds_entity_t topic) {
    const dds_entity_t r = make_reader_of<M>(p, topic, part);
    const dds_entity_t condition =
        dds_check(dds_create_readcondition(r, DDS_ANY_STATE), "dds_create_readcondition");
    dds_check(dds_waitset_attach(d.waitset, condition, r), "dds_waitset_attach");
    return r;
  };
  if (role.reads_clock) d.clock_reader = reader(static_cast<ClockTick*>(nullptr), clock);
  if (role.reads_measurements)
    d.measurement_reader = reader(static_cast<Measurement*>(nullptr), measurement);
  if (role.reads_commands) d.command_reader = reader(static_cast<CommandReport*>(nullptr), command);
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
  if (clock.answered.size() != clock.reports_sent.size() ||
      clock.answered.size() != clock.prediction_stamps.size())
    throw InputError("ClockTick", "answered, reports_sent and prediction_stamps differ in length");
  write_message(d.clock_writer, clock, d.arena);
  ++stats_.published;
}

void SimLink::publish(const Measurement& m) {
  Impl& d = *impl_;
  if (d.measurement_writer == 0)
    throw InputError("SimLink", "this role does not publish measurements");
  write_message(d.measurement_writer, m, d.arena);
  ++stats_.published;
}

void SimLink::publish(const CommandReport& c) {
  Impl& d = *impl_;
  if (d.command_writer == 0) throw InputError("SimLink", "this role does not publish commands");
  write_message(d.command_writer, c, d.arena);
  ++stats_.published;
}

std::optional<std::string> check_clock(const ClockTick& c, int num_uavs) {
  if (!(std::isfinite(c.t_s) && c.t_s >= 0.0)) return fmt::format("t_s {} is invalid", c.t_s);
  if (c.answered.size() != c.reports_sent.size() || c.answered.size() != c.prediction_stamps.size())
    return std::string("answered, reports_sent and prediction_stamps differ in length");
  for (const int uav : c.lost)
    if (auto e = check_uav(uav, num_uavs)) return e;
  for (std::size_t k = 0; k < c.answered.size(); ++k) {
    if (auto e = check_uav(c.answered[k], num_uavs)) return e;
    if (c.reports_sent[k] < 0) return std::string("a report count is negative");
    if (!std::isfinite(c.prediction_stamps[k])) return std::string("a stamp is not finite");
  }
  return std::nullopt;
}

namespace {

/// Takes M's samples from `reader` (only `uav`'s when uav ≥ 0), converts and checks them with
/// check(M, num_uavs); counts every one received and every one rejected ("Type: reason").
template <class M, class Check>
void take_checked(dds_entity_t reader, int uav, int num_uavs, Check&& check, SimLinkStats& stats,
                  std::vector<M>& out) {
  if (reader == 0) return;
  const auto reject = [&](const std::string& reason) {
    ++stats.rejected;
    stats.last_rejection = fmt::format("{}: {}", messages::WireFields<M>::name, reason);
  };
  take_messages<M>(
      reader, kMaxSequence,
      [&](const auto& sample) {
        if constexpr (requires { sample.uav; })
          if (uav >= 0 && sample.uav != uav) return true;
        ++stats.received;
        return false;
      },
      [&](M&& m) {
        if (auto reason = check(m, num_uavs)) return reject(*reason);
        out.push_back(std::move(m));
      },
      [&](const auto&, const std::string& reason) { reject(reason); });
}

}  // namespace

void SimLink::take(std::vector<ClockTick>& out) {
  take_checked(impl_->clock_reader, -1, num_uavs_, check_clock, stats_, out);
}

void SimLink::take(std::vector<Measurement>& out, int uav) {
  take_checked(impl_->measurement_reader, uav, num_uavs_, check_measurement, stats_, out);
}

void SimLink::take(std::vector<CommandReport>& out) {
  take_checked(impl_->command_reader, -1, num_uavs_, check_command, stats_, out);
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
