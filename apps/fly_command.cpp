// `ridgeline fly --uav I --udp HOST:PORT [--scenario FILE] [--duration S] [--out FILE]`: the
// offboard companion. It plans the mission (the global planner, as `ridgeline plan`), takes
// UAV I's reference (index from 0), and flies it through a MAVLink v2 vehicle at HOST:PORT
// (UDP; PX4 or `ridgeline vehicle-sim`): arms, switches to offboard, streams the tracker's
// commands at the MPC rate (50 Hz) as SET_POSITION_TARGET_LOCAL_NED (velocity + yaw rate) with
// a heartbeat at 1 Hz, and reads LOCAL_POSITION_NED and ATTITUDE back into the tracker. Mission
// time 0 is the moment the vehicle reports offboard; the flight lasts --duration seconds
// (default: to the end of the reference). Prints the tracking error against the reference;
// --out writes it as JSON. Exit 5 when the vehicle left offboard before the end.
//
// --px4-dds instead of --udp: the same flight over PX4's own DDS topics (px4/px4_pilot.hpp:
// offboard_control_mode at 50 Hz before and during offboard, arm and offboard by
// vehicle_command, trajectory_setpoint velocity + yawspeed; vehicle_odometry and vehicle_status
// back) of the vehicle in namespace --px4-namespace (default uav_<I+1>, as `run --px4-dds`
// names UAV I's), DDS domain --domain-id and partition --partition (default 0 and the default
// partition: PX4's). A vehicle that does not fly offboard within --start-timeout is one error
// naming the UAV, the topic and what was waited for (exit 2).
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/mavlink_team.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "mavlink/udp_session.hpp"
#include "mission/stage_inputs.hpp"
#include "px4/px4_pilot.hpp"
#include "sim/mission.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::apps {
namespace {

/// What went over the wire: for the summary line, and the JSON of the wire's own counters.
struct WireReport {
  std::string line;
  nlohmann::json json;
};

WireReport fly_over_px4_dds(mavlink::OffboardPilot& pilot, const std::string& name,
                            const std::string& ns, const transport_dds::DdsOptions& dds,
                            double duration_s, double period_s, double start_timeout_s) {
  transport_dds::Px4Link link(std::make_shared<transport_dds::DdsParticipant>(dds),
                              transport_dds::Px4Side::kCompanion, {ns});
  std::cerr << fmt::format(
      "fly: {} over PX4's DDS topics rt/{}fmu/ (domain {}, partition '{}') for {:.1f} s\n", name,
      ns.empty() ? "" : ns + "/", dds.domain_id, dds.partition, duration_s);
  const std::atomic<bool> never{false};
  const px4::Px4PilotReport r =
      px4::fly_px4_pilot(pilot, link, name, period_s, start_timeout_s, never);
  return {fmt::format("samples sent {}, odometry received {} ({} rejected), status received {}{}",
                      r.samples_sent, r.odometry_received, r.odometry_rejected, r.status_received,
                      r.last_rejection.empty() ? "" : "; last rejection: " + r.last_rejection),
          {{"px4_dds",
            {{"namespace", ns},
             {"domain_id", dds.domain_id},
             {"partition", dds.partition},
             {"samples_sent", r.samples_sent},
             {"odometry_received", r.odometry_received},
             {"odometry_rejected", r.odometry_rejected},
             {"status_received", r.status_received},
             {"last_rejection", r.last_rejection}}}}};
}

WireReport fly_over_mavlink(mavlink::OffboardPilot& pilot, const std::string& name,
                            const std::string& host, std::uint16_t port, double duration_s,
                            double period_s, double start_timeout_s) {
  mavlink::UdpLink link = mavlink::UdpLink::connect(host, port);
  std::cerr << fmt::format("fly: {} over MAVLink to {}:{} for {:.1f} s\n", name, host, port,
                           duration_s);
  const std::atomic<bool> never{false};
  const mavlink::SessionReport r =
      mavlink::fly_pilot(pilot, link, period_s, start_timeout_s, never);
  return {fmt::format("frames sent {}, received {} ({} rejected)", r.frames_sent,
                      r.parser.accepted(), r.parser.rejected()),
          {{"frames_sent", r.frames_sent},
           {"frames_received", r.parser.accepted()},
           {"frames_rejected", r.parser.rejected()}}};
}

}  // namespace

void register_fly_command(CLI::App& app) {
  struct Args {
    int uav = 0;
    std::string udp;
    std::string scenario;
    std::optional<double> duration_s;
    std::string out;
    double start_timeout_s = 10.0;
    int target_system = 1;
    bool px4_dds = false;
    std::optional<std::string> px4_namespace;
    int domain_id = 0;
    std::string partition;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "fly",
      "Fly one UAV's planned reference offboard through a vehicle: MAVLink over UDP, or PX4's DDS "
      "topics (--px4-dds)");
  cmd->add_option("--uav", args->uav, "Index of the scenario's UAV to fly (from 0)")->required();
  CLI::Option* udp =
      cmd->add_option("--udp", args->udp, "The vehicle's HOST:PORT, e.g. 127.0.0.1:14540");
  CLI::Option* px4_dds = cmd->add_flag(
      "--px4-dds", args->px4_dds,
      "Fly over PX4's uXRCE-DDS topics (px4_msgs, PX4 v1.14) instead of MAVLink over UDP");
  udp->excludes(px4_dds);
  CLI::Option* px4_namespace = cmd->add_option("--px4-namespace", args->px4_namespace,
                  "With --px4-dds: the vehicle's namespace (uav_N; \"\" for none; default "
                  "uav_<uav+1>)");
  CLI::Option* domain_id =
      cmd->add_option("--domain-id", args->domain_id, "With --px4-dds: DDS domain id (PX4's: 0)")
          ->capture_default_str();
  CLI::Option* partition = cmd->add_option(
      "--partition", args->partition,
      "With --px4-dds: DDS partition (empty: the default partition, as PX4 uses)");
  for (CLI::Option* option : {px4_namespace, domain_id, partition}) option->needs(px4_dds);
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--duration", args->duration_s, "Seconds of flight (default: the whole reference)");
  cmd->add_option("--out", args->out, "Write the flight's summary as JSON to this file");
  cmd->add_option("--target-system", args->target_system,
                  "The vehicle's MAVLink system id, which its commands target (PX4: MAV_SYS_ID; "
                  "SITL instance N has N + 1)")
      ->capture_default_str();
  cmd->add_option("--start-timeout", args->start_timeout_s,
                  "Seconds to wait for the vehicle to be armed and in offboard")
      ->capture_default_str();
  cmd->callback([args, udp] {
    if (!args->px4_dds && udp->count() == 0) throw InputError("--udp", "is required (or --px4-dds)");
    if (args->px4_namespace) {
      if (auto reason = transport_dds::check_px4_namespace(*args->px4_namespace))
        throw InputError("--px4-namespace", *reason);
    }
    if (args->target_system < 1 || args->target_system > 255)
      throw InputError("--target-system",
                       fmt::format("{} is not a MAVLink system id (1..255)", args->target_system));
    if (!(args->start_timeout_s > 0.0))
      throw InputError("--start-timeout",
                       fmt::format("{} s is not a positive number of seconds", args->start_timeout_s));
    const auto [host, port] =
        args->px4_dds ? std::pair<std::string, std::uint16_t>{} : mavlink::parse_host_port(args->udp);
    if (args->duration_s && !(*args->duration_s > 0.0))
      throw InputError("--duration", fmt::format("{} s is not positive", *args->duration_s));
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const mission::Scenario& sc = loaded.scenario;
    const int n = static_cast<int>(sc.uavs.size());
    if (args->uav < 0 || args->uav >= n)
      throw InputError("--uav", fmt::format("{} is not a UAV of the scenario (0..{})", args->uav, n - 1));
    const mission::UavSpec& uav = sc.uavs[static_cast<std::size_t>(args->uav)];
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded);
    if (!plan) return;
    const auto it = std::find_if(plan->uavs.begin(), plan->uavs.end(),
                                 [&](const planning::UavPlan& p) { return p.name == uav.name; });
    if (it == plan->uavs.end() || !it->timing.reference)
      throw InputError("--uav", fmt::format("{} ({}) has no reference: the allocation left it idle",
                                            args->uav, uav.name));
    const auto reference = std::make_shared<const mpc::SampledReference>(*it->timing.reference);

    mavlink::OffboardPilotOptions o;
    o.tracker = mission::make_tracker_options(sc, uav);
    o.flight_duration_s = args->duration_s.value_or(reference->end_time_s());
    o.home_altitude_m = home_altitude_m(sc);
    o.target_system = static_cast<std::uint8_t>(args->target_system);
    mavlink::OffboardPilot pilot(o, sc.safety, reference, loaded.terrain);
    const std::string name = fmt::format("{} (UAV {})", uav.name, args->uav);
    transport_dds::DdsOptions dds;
    dds.domain_id = args->domain_id;
    dds.partition = args->partition;
    const WireReport wire =
        args->px4_dds
            ? fly_over_px4_dds(pilot, name,
                               args->px4_namespace.value_or(fmt::format("uav_{}", args->uav + 1)),
                               dds, o.flight_duration_s, o.tracker.control_period_s,
                               args->start_timeout_s)
            : fly_over_mavlink(pilot, name, host, port, o.flight_duration_s,
                               o.tracker.control_period_s, args->start_timeout_s);
    const mavlink::FlightSummary s = pilot.summary();
    std::cout << fmt::format(
        "fly: {}; offboard after {:.2f} s; {} steps over {:.1f} s; tracking RMSE {:.2f} m, max "
        "{:.2f} m; {:.0f} m flown; {} stale states, {} QP fallbacks; {}\n",
        mavlink::to_string(s.phase), s.time_to_offboard_s, s.steps, s.flown_time_s,
        s.tracking_rmse_m, s.tracking_max_m, s.path_length_m, s.stale_steps, s.qp_fallbacks,
        wire.line);
    if (!args->out.empty()) {
      nlohmann::json j = {{"uav", uav.name},
                          {"phase", std::string(mavlink::to_string(s.phase))},
                          {"finished", s.phase == mavlink::PilotPhase::kFinished},
                          {"time_to_offboard_s", s.time_to_offboard_s},
                          {"steps", s.steps},
                          {"flown_time_s", s.flown_time_s},
                          {"tracking_rmse_m", s.tracking_rmse_m},
                          {"tracking_max_m", s.tracking_max_m},
                          {"path_length_m", s.path_length_m},
                          {"stale_steps", s.stale_steps},
                          {"qp_fallbacks", s.qp_fallbacks}};
      j.update(wire.json);
      nlohmann::json samples = nlohmann::json::array();
      for (const mavlink::FlightSample& f : pilot.log())
        samples.push_back({f.t_s, f.position_m.x(), f.position_m.y(), f.position_m.z(),
                           f.reference_m.x(), f.reference_m.y(), f.reference_m.z()});
      j["samples"] = {{"columns", {"t", "x", "y", "z", "ref_x", "ref_y", "ref_z"}},
                      {"rows", samples}};
      io::write_file_atomically(args->out, j.dump() + "\n");
    }
    if (s.phase != mavlink::PilotPhase::kFinished) {
      std::cerr << "error: the flight ended early: " << mavlink::to_string(s.phase) << '\n';
      set_exit_code(5);
    }
  });
}

}  // namespace ridgeline::apps
