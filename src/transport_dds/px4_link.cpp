#include "transport_dds/px4_link.hpp"

#include <fmt/format.h>

#include <array>
#include <set>

#include "core/error.hpp"
#include "transport_dds/wire_types.hpp"

namespace ridgeline::transport_dds {

std::optional<std::string> check_px4_namespace(const std::string& ns) {
  if (ns.empty()) return std::nullopt;
  const std::string prefix = "uav_";
  const std::string digits = ns.substr(std::min(ns.size(), prefix.size()));
  const bool number = !digits.empty() && digits.size() <= 3 &&
                      digits.find_first_not_of("0123456789") == std::string::npos &&
                      (digits == "0" || digits[0] != '0');
  if (ns.compare(0, prefix.size(), prefix) != 0 || !number)
    return fmt::format("'{}' is not a PX4 vehicle namespace (uav_N, e.g. uav_1, or empty)", ns);
  return std::nullopt;
}

std::string px4_topic_name(const std::string& topic, const std::string& ns) {
  const std::string root = "rt/";
  return ns.empty() ? topic : root + ns + "/" + topic.substr(root.size());
}

namespace {

constexpr std::size_t kTypes = std::variant_size_v<Px4Message>;

/// The position of M in Px4Message.
template <class M, std::size_t I = 0>
constexpr std::size_t type_index() {
  static_assert(I < kTypes, "not a PX4 message of Px4Message");
  if constexpr (std::is_same_v<std::variant_alternative_t<I, Px4Message>, M>)
    return I;
  else
    return type_index<M, I + 1>();
}

/// Whether `side` writes (else reads) message type I.
bool writes(Px4Side side, std::size_t index) {
  const bool companion_type = index <= type_index<px4::VehicleCommand>();
  return (side == Px4Side::kCompanion) == companion_type;
}

}  // namespace

struct Px4Link::Impl {
  std::shared_ptr<DdsParticipant> participant;
  Px4Side side = Px4Side::kCompanion;
  /// Per vehicle, per message type: its writer or its reader.
  std::vector<std::array<dds_entity_t, kTypes>> entities;
  dds_entity_t waitset = 0;
  WireArena arena;
};

Px4Link::Px4Link(std::shared_ptr<DdsParticipant> participant, Px4Side side,
                 std::vector<std::string> namespaces)
    : impl_(std::make_unique<Impl>()), namespaces_(std::move(namespaces)) {
  if (participant == nullptr) throw InputError("participant", "is required");
  if (namespaces_.empty()) throw InputError("namespaces", "at least one vehicle is needed");
  std::set<std::string> seen;
  for (const std::string& ns : namespaces_) {
    if (auto reason = check_px4_namespace(ns)) throw InputError("namespaces", *reason);
    if (!seen.insert(ns).second)
      throw InputError("namespaces", fmt::format("'{}' is given twice", ns));
  }
  if (namespaces_.size() > 1 && seen.count("") > 0)
    throw InputError("namespaces", "a vehicle without a namespace must be the only one");
  Impl& d = *impl_;
  d.participant = std::move(participant);
  d.side = side;
  const dds_entity_t p = d.participant->handle();
  const std::string& partition = d.participant->partition();
  d.waitset = dds_check(dds_create_waitset(p), "dds_create_waitset");
  for (const std::string& ns : namespaces_) {
    std::array<dds_entity_t, kTypes> e{};
    auto add = [&]<std::size_t I>(std::integral_constant<std::size_t, I>) {
      using M = std::variant_alternative_t<I, Px4Message>;
      const TopicSpec& spec = Topic<M>::spec;
      const dds_entity_t topic =
          make_topic(p, WireType<M>::descriptor(), px4_topic_name(spec.name, ns).c_str());
      if (writes(side, I)) {
        e[I] = make_writer(p, topic, spec.qos, spec.depth, partition);
      } else {
        e[I] = make_reader(p, topic, spec.qos, spec.depth, partition);
        const dds_entity_t condition =
            dds_check(dds_create_readcondition(e[I], DDS_ANY_STATE), "dds_create_readcondition");
        dds_check(dds_waitset_attach(d.waitset, condition, e[I]), "dds_waitset_attach");
      }
    };
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      (add(std::integral_constant<std::size_t, I>{}), ...);
    }
    (std::make_index_sequence<kTypes>{});
    d.entities.push_back(e);
  }
}

Px4Link::~Px4Link() {
  const Impl& d = *impl_;
  dds_delete(d.waitset);
  for (const auto& e : d.entities)
    for (const dds_entity_t entity : e)
      if (entity > 0) dds_delete(entity);
}

template <class M>
void Px4Link::publish(int vehicle, const M& message) {
  Impl& d = *impl_;
  constexpr std::size_t index = type_index<M>();
  if (!writes(d.side, index))
    throw InputError("Px4Link",
                     fmt::format("this side does not publish {}", messages::WireFields<M>::name));
  if (vehicle < 0 || vehicle >= size())
    throw InputError("vehicle",
                     fmt::format("{} is not one of the link's {} vehicles", vehicle, size()));
  write_message(d.entities[static_cast<std::size_t>(vehicle)][index], message, d.arena);
}
template void Px4Link::publish(int, const px4::OffboardControlMode&);
template void Px4Link::publish(int, const px4::TrajectorySetpoint&);
template void Px4Link::publish(int, const px4::VehicleCommand&);
template void Px4Link::publish(int, const px4::VehicleOdometry&);
template void Px4Link::publish(int, const px4::VehicleStatus&);

void Px4Link::take(std::vector<Px4Received>& out) {
  Impl& d = *impl_;
  for (std::size_t v = 0; v < d.entities.size(); ++v) {
    auto take_one = [&]<std::size_t I>(std::integral_constant<std::size_t, I>) {
      using M = std::variant_alternative_t<I, Px4Message>;
      if (writes(d.side, I)) return;
      // PX4's messages hold no sequence, so a conversion never refuses a sample.
      take_messages<M>(
          d.entities[v][I], 0, [](const auto&) { return false; },
          [&](M&& m) {
            out.push_back({static_cast<int>(v), Px4Message(std::move(m))});
          },
          [](const auto&, const std::string&) {});
    };
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      (take_one(std::integral_constant<std::size_t, I>{}), ...);
    }
    (std::make_index_sequence<kTypes>{});
  }
}

bool Px4Link::wait(double timeout_s) {
  const dds_duration_t timeout =
      timeout_s <= 0.0 ? 0 : static_cast<dds_duration_t>(timeout_s * 1e9);
  return dds_waitset_wait(impl_->waitset, nullptr, 0, timeout) > 0;
}

}  // namespace ridgeline::transport_dds
