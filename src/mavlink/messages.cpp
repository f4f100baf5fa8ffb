#include "mavlink/messages.hpp"

#include <bit>
#include <cstring>

namespace ridgeline::mavlink {
namespace {

// Published in the MAVLink definitions (common.xml; message id, CRC_EXTRA, length). The field
// tables must reproduce them.
static_assert(compute_crc_extra<Heartbeat>() == 50 && payload_size<Heartbeat>() == 9);
static_assert(compute_crc_extra<Attitude>() == 39 && payload_size<Attitude>() == 28);
static_assert(compute_crc_extra<LocalPositionNed>() == 185 && payload_size<LocalPositionNed>() == 28);
static_assert(compute_crc_extra<CommandLong>() == 152 && payload_size<CommandLong>() == 33);
static_assert(compute_crc_extra<SetPositionTargetLocalNed>() == 143 &&
              payload_size<SetPositionTargetLocalNed>() == 53);

template <class M>
constexpr MessageSpec spec_of() {
  return {M::kId, M::kName, compute_crc_extra<M>(), static_cast<std::uint8_t>(payload_size<M>())};
}
constexpr std::array<MessageSpec, 5> kSpecs = {spec_of<Heartbeat>(), spec_of<Attitude>(),
                                               spec_of<LocalPositionNed>(), spec_of<CommandLong>(),
                                               spec_of<SetPositionTargetLocalNed>()};

// Little-endian on the wire whatever the host's order.
template <class T>
void put(const T& value, std::uint8_t*& out) {
  using U = std::conditional_t<sizeof(T) == 1, std::uint8_t,
                               std::conditional_t<sizeof(T) == 2, std::uint16_t, std::uint32_t>>;
  const U bits = std::bit_cast<U>(value);
  for (std::size_t i = 0; i < sizeof(T); ++i) *out++ = static_cast<std::uint8_t>(bits >> (8 * i));
}

template <class T>
T get(const std::uint8_t*& in) {
  using U = std::conditional_t<sizeof(T) == 1, std::uint8_t,
                               std::conditional_t<sizeof(T) == 2, std::uint16_t, std::uint32_t>>;
  U bits = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) bits = static_cast<U>(bits | (U(*in++) << (8 * i)));
  return std::bit_cast<T>(bits);
}

}  // namespace

const MessageSpec* find_message_spec(std::uint32_t message_id) {
  for (const MessageSpec& s : kSpecs)
    if (s.id == message_id) return &s;
  return nullptr;
}

template <class M>
std::array<std::uint8_t, payload_size<M>()> encode_payload(const M& message) {
  std::array<std::uint8_t, payload_size<M>()> out{};
  std::uint8_t* p = out.data();
  std::apply([&](const auto&... f) { (put(message.*(f.member), p), ...); }, M::fields);
  return out;
}

template <class M>
M decode_payload(std::span<const std::uint8_t> payload) {
  M message{};
  if (payload.size() < payload_size<M>()) return message;  // callers pass zero-extended payloads
  const std::uint8_t* p = payload.data();
  std::apply(
      [&](const auto&... f) {
        ((message.*(f.member) = get<std::remove_cvref_t<decltype(message.*(f.member))>>(p)), ...);
      },
      M::fields);
  return message;
}

#define RIDGELINE_MAVLINK_INSTANTIATE(M)                                                   \
  template std::array<std::uint8_t, payload_size<M>()> encode_payload<M>(const M&);       \
  template M decode_payload<M>(std::span<const std::uint8_t>);
RIDGELINE_MAVLINK_INSTANTIATE(Heartbeat)
RIDGELINE_MAVLINK_INSTANTIATE(Attitude)
RIDGELINE_MAVLINK_INSTANTIATE(LocalPositionNed)
RIDGELINE_MAVLINK_INSTANTIATE(CommandLong)
RIDGELINE_MAVLINK_INSTANTIATE(SetPositionTargetLocalNed)
#undef RIDGELINE_MAVLINK_INSTANTIATE

EncodedFrame encode_message(const Message& message, const FrameHeader& header) {
  return std::visit([&](const auto& m) { return encode_message(m, header); }, message);
}

std::optional<Message> decode_message(const Frame& frame) {
  const std::span<const std::uint8_t> payload(frame.payload);
  switch (frame.message_id) {
    case Heartbeat::kId: return decode_payload<Heartbeat>(payload);
    case Attitude::kId: return decode_payload<Attitude>(payload);
    case LocalPositionNed::kId: return decode_payload<LocalPositionNed>(payload);
    case CommandLong::kId: return decode_payload<CommandLong>(payload);
    case SetPositionTargetLocalNed::kId: return decode_payload<SetPositionTargetLocalNed>(payload);
    default: return std::nullopt;
  }
}

std::string_view message_name(const Message& message) {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kName; }, message);
}

}  // namespace ridgeline::mavlink
