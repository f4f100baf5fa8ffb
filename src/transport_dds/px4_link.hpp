// PX4's topics over DDS (issue 22): one participant's end of the uXRCE-DDS topics of one or more
// PX4 vehicles, either the companion's (writes fmu/in, reads fmu/out) or the vehicle's (the
// reverse: `ridgeline vehicle-sim --px4-dds`, PX4's stand-in). Vehicle i's topics live under its
// namespace: rt/fmu/... without one (a single PX4), rt/uav_N/fmu/... with `uav_N` (PX4's
// multi-vehicle namespace, `uxrce_dds_client start -n uav_N`). Types, topics and QoS:
// px4_messages.hpp and topics.hpp. No DDS type in this header.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "transport_dds/dds_participant.hpp"
#include "transport_dds/px4_messages.hpp"

namespace ridgeline::transport_dds {

/// Why `ns` is not a PX4 vehicle namespace ("" or uav_N, N in 0..999 without leading zeros),
/// or nothing when it is one.
std::optional<std::string> check_px4_namespace(const std::string& ns);
/// The DDS topic `topic` (a name of topics.hpp, rt/fmu/...) of the vehicle in namespace `ns`.
std::string px4_topic_name(const std::string& topic, const std::string& ns);

enum class Px4Side {
  kCompanion,  ///< publishes OffboardControlMode, TrajectorySetpoint, VehicleCommand
  kVehicle,    ///< publishes VehicleOdometry, VehicleStatus
};

using Px4Message = std::variant<px4::OffboardControlMode, px4::TrajectorySetpoint,
                                px4::VehicleCommand, px4::VehicleOdometry, px4::VehicleStatus>;

struct Px4Received {
  int vehicle = -1;  ///< index into the link's namespaces
  Px4Message message;
};

class Px4Link {
 public:
  /// Throws InputError("namespaces", ...) naming a namespace that is not one (or repeated).
  Px4Link(std::shared_ptr<DdsParticipant> participant, Px4Side side,
          std::vector<std::string> namespaces);
  ~Px4Link();
  Px4Link(const Px4Link&) = delete;
  Px4Link& operator=(const Px4Link&) = delete;

  /// Writes `message` on vehicle i's topic of its type. Throws InputError when this side does
  /// not publish that type.
  template <class M>
  void publish(int vehicle, const M& message);
  /// Appends every sample received since the last call, with the vehicle it came for.
  void take(std::vector<Px4Received>& out);
  /// Blocks until a reader has data or timeout_s has passed; true if data.
  bool wait(double timeout_s);

  int size() const { return static_cast<int>(namespaces_.size()); }
  const std::string& vehicle_namespace(int vehicle) const {
    return namespaces_[static_cast<std::size_t>(vehicle)];
  }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<std::string> namespaces_;
};

}  // namespace ridgeline::transport_dds
