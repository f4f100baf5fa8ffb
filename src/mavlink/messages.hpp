// The MAVLink messages an offboard companion and its vehicle exchange (common.xml), each a
// plain struct whose `fields` table, in wire order, is the one description of its layout:
// encoding, decoding, the payload size and the CRC_EXTRA byte are all derived from it.
//
// Wire order is common.xml's field order sorted by type size, largest first (stable); none of
// these messages has extension fields. CRC_EXTRA is computed as MAVLink's generator does:
// X.25 over "NAME " then, per base field in wire order, "type " and "name "; the byte is the
// checksum's low byte XOR its high byte. The static_asserts in messages.cpp tie each table to
// the CRC_EXTRA and length published in the MAVLink definitions, so a wrong field order, type
// or name does not compile.
//
// Units and frames are MAVLink's: positions in metres, local frame NED (x north, y east,
// z down), angles in radians, yaw from north clockwise. ned_frame.hpp converts to and from
// Ridgeline's ENU.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <span>
#include <tuple>
#include <type_traits>
#include <variant>

#include "mavlink/frame.hpp"
#include "mavlink/x25_crc.hpp"

namespace ridgeline::mavlink {

template <class Message, class T>
struct Field {
  std::string_view name;
  T Message::*member;
};
template <class Message, class T>
constexpr Field<Message, T> field(std::string_view name, T Message::*member) {
  return {name, member};
}

// MAV_TYPE, MAV_AUTOPILOT, MAV_MODE_FLAG, MAV_STATE, MAV_CMD, MAV_FRAME values used here.
constexpr std::uint8_t kMavTypeHexarotor = 13;
constexpr std::uint8_t kMavTypeOnboardController = 18;
constexpr std::uint8_t kMavAutopilotPx4 = 12;
constexpr std::uint8_t kMavAutopilotInvalid = 8;
constexpr std::uint8_t kModeFlagCustomModeEnabled = 1;
constexpr std::uint8_t kModeFlagSafetyArmed = 128;
constexpr std::uint8_t kMavStateStandby = 3;
constexpr std::uint8_t kMavStateActive = 4;
constexpr std::uint16_t kMavCmdComponentArmDisarm = 400;
constexpr std::uint16_t kMavCmdDoSetMode = 176;
constexpr std::uint8_t kMavFrameLocalNed = 1;
/// PX4's custom mode: main mode in bits 16–23; OFFBOARD is main mode 6.
constexpr std::uint32_t kPx4MainModeOffboard = 6;
constexpr std::uint32_t kPx4CustomModeOffboard = kPx4MainModeOffboard << 16;

/// POSITION_TARGET_TYPEMASK: a set bit means "ignore this field".
enum PositionTargetIgnore : std::uint16_t {
  kIgnoreX = 1, kIgnoreY = 2, kIgnoreZ = 4,
  kIgnoreVx = 8, kIgnoreVy = 16, kIgnoreVz = 32,
  kIgnoreAx = 64, kIgnoreAy = 128, kIgnoreAz = 256,
  kForceIsSet = 512, kIgnoreYaw = 1024, kIgnoreYawRate = 2048,
};
/// Velocity and yaw rate only: what the tracker commands.
constexpr std::uint16_t kTypeMaskVelocityYawRate =
    kIgnoreX | kIgnoreY | kIgnoreZ | kIgnoreAx | kIgnoreAy | kIgnoreAz | kIgnoreYaw;
/// Position only: how the companion tells the vehicle to stop and hold (a finished UAV).
constexpr std::uint16_t kTypeMaskPositionHold = kIgnoreVx | kIgnoreVy | kIgnoreVz | kIgnoreAx |
                                                kIgnoreAy | kIgnoreAz | kIgnoreYaw |
                                                kIgnoreYawRate;

/// HEARTBEAT (0): who is there and in which state; sent at 1 Hz by every component.
struct Heartbeat {
  static constexpr std::uint32_t kId = 0;
  static constexpr std::string_view kName = "HEARTBEAT";
  std::uint32_t custom_mode = 0;
  std::uint8_t type = 0;
  std::uint8_t autopilot = 0;
  std::uint8_t base_mode = 0;
  std::uint8_t system_status = 0;
  std::uint8_t mavlink_version = 3;
  static constexpr auto fields = std::make_tuple(
      field("custom_mode", &Heartbeat::custom_mode), field("type", &Heartbeat::type),
      field("autopilot", &Heartbeat::autopilot), field("base_mode", &Heartbeat::base_mode),
      field("system_status", &Heartbeat::system_status),
      field("mavlink_version", &Heartbeat::mavlink_version));
  bool operator==(const Heartbeat&) const = default;
};

/// ATTITUDE (30): roll, pitch, yaw (rad, NED body frame) and their rates (rad/s).
struct Attitude {
  static constexpr std::uint32_t kId = 30;
  static constexpr std::string_view kName = "ATTITUDE";
  std::uint32_t time_boot_ms = 0;
  float roll = 0, pitch = 0, yaw = 0, rollspeed = 0, pitchspeed = 0, yawspeed = 0;
  static constexpr auto fields = std::make_tuple(
      field("time_boot_ms", &Attitude::time_boot_ms), field("roll", &Attitude::roll),
      field("pitch", &Attitude::pitch), field("yaw", &Attitude::yaw),
      field("rollspeed", &Attitude::rollspeed), field("pitchspeed", &Attitude::pitchspeed),
      field("yawspeed", &Attitude::yawspeed));
  bool operator==(const Attitude&) const = default;
};

/// LOCAL_POSITION_NED (32): position (m) and velocity (m/s) in the local NED frame.
struct LocalPositionNed {
  static constexpr std::uint32_t kId = 32;
  static constexpr std::string_view kName = "LOCAL_POSITION_NED";
  std::uint32_t time_boot_ms = 0;
  float x = 0, y = 0, z = 0, vx = 0, vy = 0, vz = 0;
  static constexpr auto fields = std::make_tuple(
      field("time_boot_ms", &LocalPositionNed::time_boot_ms), field("x", &LocalPositionNed::x),
      field("y", &LocalPositionNed::y), field("z", &LocalPositionNed::z),
      field("vx", &LocalPositionNed::vx), field("vy", &LocalPositionNed::vy),
      field("vz", &LocalPositionNed::vz));
  bool operator==(const LocalPositionNed&) const = default;
};

/// COMMAND_LONG (76): a command with up to seven float parameters (arm, set mode, ...).
struct CommandLong {
  static constexpr std::uint32_t kId = 76;
  static constexpr std::string_view kName = "COMMAND_LONG";
  float param1 = 0, param2 = 0, param3 = 0, param4 = 0, param5 = 0, param6 = 0, param7 = 0;
  std::uint16_t command = 0;
  std::uint8_t target_system = 0;
  std::uint8_t target_component = 0;
  std::uint8_t confirmation = 0;
  static constexpr auto fields = std::make_tuple(
      field("param1", &CommandLong::param1), field("param2", &CommandLong::param2),
      field("param3", &CommandLong::param3), field("param4", &CommandLong::param4),
      field("param5", &CommandLong::param5), field("param6", &CommandLong::param6),
      field("param7", &CommandLong::param7), field("command", &CommandLong::command),
      field("target_system", &CommandLong::target_system),
      field("target_component", &CommandLong::target_component),
      field("confirmation", &CommandLong::confirmation));
  bool operator==(const CommandLong&) const = default;
};

/// SET_POSITION_TARGET_LOCAL_NED (84): a setpoint in the local NED frame; type_mask says
/// which of position, velocity, acceleration, yaw and yaw rate to use.
struct SetPositionTargetLocalNed {
  static constexpr std::uint32_t kId = 84;
  static constexpr std::string_view kName = "SET_POSITION_TARGET_LOCAL_NED";
  std::uint32_t time_boot_ms = 0;
  float x = 0, y = 0, z = 0, vx = 0, vy = 0, vz = 0, afx = 0, afy = 0, afz = 0;
  float yaw = 0, yaw_rate = 0;
  std::uint16_t type_mask = 0;
  std::uint8_t target_system = 0;
  std::uint8_t target_component = 0;
  std::uint8_t coordinate_frame = kMavFrameLocalNed;
  using S = SetPositionTargetLocalNed;
  static constexpr auto fields = std::make_tuple(
      field("time_boot_ms", &S::time_boot_ms), field("x", &S::x), field("y", &S::y),
      field("z", &S::z), field("vx", &S::vx), field("vy", &S::vy), field("vz", &S::vz),
      field("afx", &S::afx), field("afy", &S::afy), field("afz", &S::afz), field("yaw", &S::yaw),
      field("yaw_rate", &S::yaw_rate), field("type_mask", &S::type_mask),
      field("target_system", &S::target_system), field("target_component", &S::target_component),
      field("coordinate_frame", &S::coordinate_frame));
  bool operator==(const SetPositionTargetLocalNed&) const = default;
};

using Message =
    std::variant<Heartbeat, Attitude, LocalPositionNed, CommandLong, SetPositionTargetLocalNed>;

// --- derived from the field tables -------------------------------------------------------

template <class T>
constexpr std::string_view mavlink_type_name() {
  if constexpr (std::is_same_v<T, std::uint8_t>) return "uint8_t";
  else if constexpr (std::is_same_v<T, std::uint16_t>) return "uint16_t";
  else if constexpr (std::is_same_v<T, std::uint32_t>) return "uint32_t";
  else if constexpr (std::is_same_v<T, float>) return "float";
  else static_assert(sizeof(T) == 0, "field type not used by these messages");
}

/// Untruncated payload size in bytes.
template <class M>
constexpr std::size_t payload_size() {
  return std::apply([](const auto&... f) { return (sizeof(decltype(M{}.*(f.member))) + ...); },
                    M::fields);
}

/// CRC_EXTRA from the message's name and base fields (see the header comment).
template <class M>
constexpr std::uint8_t compute_crc_extra() {
  std::uint16_t crc = x25_accumulate(M::kName, kX25InitialValue);
  crc = x25_accumulate(std::string_view(" "), crc);
  std::apply(
      [&crc](const auto&... f) {
        ((crc = x25_accumulate(
              std::string_view(" "),
              x25_accumulate(f.name,
                             x25_accumulate(std::string_view(" "),
                                            x25_accumulate(mavlink_type_name<std::remove_cvref_t<
                                                               decltype(M{}.*(f.member))>>(),
                                                           crc))))),
         ...);
      },
      M::fields);
  return static_cast<std::uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

/// The message's untruncated payload.
template <class M>
std::array<std::uint8_t, payload_size<M>()> encode_payload(const M& message);

/// Reads a zero-extended payload (at least payload_size<M>() bytes).
template <class M>
M decode_payload(std::span<const std::uint8_t> payload);

/// A complete frame for `message`.
template <class M>
EncodedFrame encode_message(const M& message, const FrameHeader& header) {
  const auto payload = encode_payload(message);
  return encode_frame(header, M::kId, payload);
}
EncodedFrame encode_message(const Message& message, const FrameHeader& header);

/// The message a frame carries, or nothing when its id is not one of `Message`'s.
std::optional<Message> decode_message(const Frame& frame);

std::string_view message_name(const Message& message);

}  // namespace ridgeline::mavlink
