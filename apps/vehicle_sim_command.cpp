// `ridgeline vehicle-sim --udp PORT [--uav I] [--scenario FILE] [--duration S]`: a MAVLink v2
// vehicle on 127.0.0.1:PORT (UDP), the stand-in for PX4 SITL. It starts hovering at UAV I's
// start (position and heading of the scenario, index from 0), integrates the vehicle model
// with RK4 at the scenario's truth rate and its model mismatch (lags truth_time_constant_scale
// times the controller's) from the velocity + yaw-rate setpoints it receives in offboard mode,
// and reports LOCAL_POSITION_NED and ATTITUDE at 50 Hz and HEARTBEAT at 1 Hz to whoever sent
// to it last. No wind unless --wind (the scenario's seeded field, the mission truth's). Its local
// NED frame is centred on the home position: with a geodetic origin, the origin's altitude
// (apps/mavlink_team.hpp). Runs until --duration has passed (default: until SIGINT/SIGTERM),
// then prints what it received.
//
// --lockstep: the clock advances one control period (the scenario's mpc.control_period_s) per
// setpoint stamped with its time, as `ridgeline run --mavlink` drives it (SimulatedVehicle's
// lock step); --peer HOST:PORT: where it announces itself until a companion talks to it;
// --udp 0 takes any free port (printed); --cruise-start: it leaves the hover at the scenario's
// start speed when offboard starts, as the mission's truth starts a UAV.
//
// --px4-dds: the same vehicle on PX4's own DDS topics instead of MAVLink (px4/px4_vehicle.hpp):
// it reads rt/<ns>/fmu/in/{offboard_control_mode, trajectory_setpoint, vehicle_command} and
// publishes rt/<ns>/fmu/out/{vehicle_status, vehicle_odometry}, ns the --px4-namespace (uav_N;
// "" for none), in DDS domain --domain-id and partition --partition: in real time (odometry at
// 50 Hz, status at 2 Hz and on a change) for `ridgeline fly --px4-dds`, or with --lockstep
// answering each step as `ridgeline run --px4-dds` drives it.
#include <csignal>
#include <iostream>

#include <fmt/format.h>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/mavlink_team.hpp"
#include "core/error.hpp"
#include "mavlink/udp_session.hpp"
#include "px4/px4_vehicle.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::apps {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void request_stop(int) { g_stop.store(true); }

}  // namespace

void register_vehicle_sim_command(CLI::App& app) {
  struct Args {
    int port = 0;
    int uav = 0;
    std::string scenario;
    double duration_s = 0.0;
    bool lockstep = false;
    bool wind = false;
    bool cruise_start = false;
    std::string peer;
    bool px4_dds = false;
    std::string px4_namespace = "uav_1";
    int domain_id = 0;
    std::string partition;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "vehicle-sim",
      "A vehicle for `ridgeline fly`/`run` (stand-in for PX4 SITL): MAVLink on 127.0.0.1 UDP, or "
      "PX4's DDS topics (--px4-dds)");
  CLI::Option* udp =
      cmd->add_option("--udp", args->port, "UDP port to listen on (127.0.0.1; 0: any free port)");
  CLI::Option* px4_dds = cmd->add_flag(
      "--px4-dds", args->px4_dds,
      "Serve PX4's uXRCE-DDS topics (px4_msgs, PX4 v1.14) instead of MAVLink");
  udp->excludes(px4_dds);
  cmd->add_option("--px4-namespace", args->px4_namespace,
                  "With --px4-dds: the vehicle's namespace (uav_N; \"\" for none)")
      ->capture_default_str();
  cmd->add_option("--domain-id", args->domain_id, "With --px4-dds: DDS domain id (PX4's: 0)")
      ->capture_default_str();
  cmd->add_option("--partition", args->partition,
                  "With --px4-dds: DDS partition (empty: the default partition, as PX4 uses)");
  cmd->add_flag("--lockstep", args->lockstep,
                "Lock step: advance one control period per setpoint stamped with its time");
  cmd->add_option("--peer", args->peer, "HOST:PORT to announce itself to until a companion talks");
  cmd->add_flag("--wind", args->wind, "Drift with the scenario's wind field (the mission truth's)");
  cmd->add_flag("--cruise-start", args->cruise_start,
                "Enter offboard at the scenario's start speed (as the mission's truth starts)");
  cmd->add_option("--uav", args->uav, "Index of the scenario's UAV whose start it takes (from 0)")
      ->capture_default_str();
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--duration", args->duration_s, "Seconds to run (0: until interrupted)")
      ->capture_default_str();
  cmd->callback([args, udp] {
    if (!args->px4_dds && udp->count() == 0)
      throw InputError("--udp", "is required (or --px4-dds)");
    if (args->px4_dds && !args->peer.empty())
      throw InputError("--peer", "is for MAVLink over UDP, not --px4-dds");
    if (args->px4_dds) {
      if (auto reason = transport_dds::check_px4_namespace(args->px4_namespace))
        throw InputError("--px4-namespace", *reason);
    }
    if (args->port < 0 || args->port > 65535)
      throw InputError("--udp",
                       fmt::format("port {} is not in 1..65535 (or 0: any free port)", args->port));
    std::optional<std::pair<std::string, std::uint16_t>> peer;
    if (!args->peer.empty()) {
      try {
        peer = mavlink::parse_host_port(args->peer);
      } catch (const InputError& e) {
        throw InputError("--peer", e.reason());
      }
    }
    if (!(args->duration_s >= 0.0))
      throw InputError("--duration", fmt::format("{} s is negative", args->duration_s));
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const mission::Scenario& sc = loaded.scenario;
    const int n = static_cast<int>(sc.uavs.size());
    if (args->uav < 0 || args->uav >= n)
      throw InputError("--uav", fmt::format("{} is not a UAV of the scenario (0..{})", args->uav, n - 1));
    const mission::UavSpec& uav = sc.uavs[static_cast<std::size_t>(args->uav)];

    mavlink::SimulatedVehicleOptions o;
    o.params = uav.vehicle;
    o.params.tau_v_s *= sc.simulation.truth_time_constant_scale;
    o.params.tau_omega_s *= sc.simulation.truth_time_constant_scale;
    o.params.tau_w_s *= sc.simulation.truth_time_constant_scale;
    o.integration_step_s = 1.0 / sc.simulation.truth_rate_hz;
    o.initial_state = vehicle::State::Zero();
    o.initial_state.head<3>() = uav.start_position_m;
    o.initial_state[vehicle::kPsi] = uav.start_heading_rad;
    o.home_altitude_m = home_altitude_m(sc);
    if (args->wind) o.wind = sc.wind;
    if (args->cruise_start) o.offboard_entry_speed_m_s = uav.start_speed_m_s;
    mavlink::SimulatedVehicle vehicle(o);
    std::signal(SIGINT, request_stop);
    std::signal(SIGTERM, request_stop);
    if (args->px4_dds) {
      transport_dds::DdsOptions dds;
      dds.domain_id = args->domain_id;
      dds.partition = args->partition;
      transport_dds::Px4Link link(std::make_shared<transport_dds::DdsParticipant>(dds),
                                  transport_dds::Px4Side::kVehicle, {args->px4_namespace});
      std::cerr << fmt::format(
          "vehicle-sim: {} ({}) on PX4's DDS topics rt/{}fmu/ (domain {}, partition '{}') {}\n",
          uav.name, args->uav, args->px4_namespace.empty() ? "" : args->px4_namespace + "/",
          dds.domain_id, dds.partition, args->lockstep ? "in lock step" : "in real time");
      const px4::Px4VehicleStats s =
          args->lockstep ? px4::serve_px4_vehicle_lockstep(vehicle, link, sc.mpc.control_period_s,
                                                           args->duration_s, g_stop)
                         : px4::serve_px4_vehicle(vehicle, link, args->duration_s, g_stop);
      const mavlink::SimulatedVehicleStats& v = vehicle.stats();
      std::cout << fmt::format(
          "vehicle-sim: {:.1f} s; received {} offboard_control_mode, {} trajectory_setpoint ({} "
          "rejected), {} vehicle_command ({} refused, {} refused by the vehicle); {} offboard "
          "timeouts; {} lock-step steps ({} resent, {} out of step); {} odometry, {} status sent; "
          "final position ENU ({:.1f}, {:.1f}, {:.1f}) m{}\n",
          s.wall_time_s, s.offboard_control_modes, s.setpoints, s.setpoints_rejected, s.commands,
          s.commands_refused, v.commands_refused, v.offboard_timeouts, v.lockstep_steps,
          v.lockstep_duplicates, v.lockstep_out_of_step, s.replies,
          s.status_sent, vehicle.state()[vehicle::kX],
          vehicle.state()[vehicle::kY], vehicle.state()[vehicle::kZ],
          s.last_rejection.empty() ? "" : "; last rejection: " + s.last_rejection);
      return;
    }
    mavlink::UdpLink link =
        mavlink::UdpLink::listen("127.0.0.1", static_cast<std::uint16_t>(args->port));
    if (peer) link.set_peer(peer->first, peer->second);
    std::cerr << fmt::format("vehicle-sim: {} ({}) listening on 127.0.0.1:{}{}\n", uav.name,
                             args->uav, link.local_port(),
                             args->lockstep ? " in lock step" : "");
    const mavlink::SessionReport r =
        args->lockstep ? mavlink::serve_vehicle_lockstep(vehicle, link, sc.mpc.control_period_s,
                                                         args->duration_s, g_stop)
                       : mavlink::serve_vehicle(vehicle, link, args->duration_s, g_stop);
    const mavlink::SimulatedVehicleStats& s = vehicle.stats();
    std::cout << fmt::format(
        "vehicle-sim: {:.1f} s; received {} frames ({} rejected by the parser), {} setpoints "
        "({} refused), {} commands ({} refused), {} offboard timeouts; {} lock-step steps ({} "
        "resent, {} out of step); sent {} frames; final position ENU ({:.1f}, {:.1f}, {:.1f}) "
        "m{}\n",
        r.wall_time_s, r.parser.accepted(), r.parser.rejected(), s.setpoints, s.setpoints_rejected,
        s.commands, s.commands_refused, s.offboard_timeouts, s.lockstep_steps,
        s.lockstep_duplicates, s.lockstep_out_of_step, r.frames_sent,
        vehicle.state()[vehicle::kX], vehicle.state()[vehicle::kY], vehicle.state()[vehicle::kZ],
        s.last_error.empty() ? "" : "; last refusal: " + s.last_error);
  });
}

}  // namespace ridgeline::apps
