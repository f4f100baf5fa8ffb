#include "swarm/in_process_transport.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"

namespace ridgeline::swarm {

InProcessTransport::InProcessTransport(int num_participants, const LinkModel& link,
                                       std::uint64_t seed)
    : num_participants_(num_participants), link_(link), rng_(seed) {
  if (num_participants < 1) throw InputError("transport", "needs at least one participant");
  if (!(std::isfinite(link.latency_s) && link.latency_s >= 0.0))
    throw InputError("link.latency_s", fmt::format("must be >= 0, got {}", link.latency_s));
  if (!(std::isfinite(link.jitter_s) && link.jitter_s >= 0.0))
    throw InputError("link.jitter_s", fmt::format("must be >= 0, got {}", link.jitter_s));
  if (!(link.drop_rate >= 0.0 && link.drop_rate <= 1.0))
    throw InputError("link.drop_rate", fmt::format("must be in [0, 1], got {}", link.drop_rate));
  inboxes_.resize(static_cast<std::size_t>(num_participants));
}

void InProcessTransport::publish(int sender, double now_s, const Message& message) {
  ++stats_.published;
  const auto shared = std::make_shared<const Message>(message);
  for (int receiver = 0; receiver < num_participants_; ++receiver) {
    if (receiver == sender) continue;
    ++stats_.sent;
    // Draw both numbers for every copy so the random stream does not depend on the outcome.
    const double loss_draw = rng_.uniform();
    const double jitter = link_.jitter_s * rng_.uniform();
    if (loss_draw < link_.drop_rate) {
      ++stats_.dropped;
      continue;
    }
    inboxes_[static_cast<std::size_t>(receiver)].push(
        Pending{sender, now_s, now_s + link_.latency_s + jitter, next_sequence_++, shared});
  }
}

void InProcessTransport::receive(int receiver, double now_s, std::vector<Envelope>& out) {
  if (receiver < 0 || receiver >= num_participants_) return;
  auto& inbox = inboxes_[static_cast<std::size_t>(receiver)];
  while (!inbox.empty() && inbox.top().delivered_s <= now_s) {
    const Pending& p = inbox.top();
    out.push_back(Envelope{p.sender, p.sent_s, p.delivered_s, *p.message});
    inbox.pop();
    ++stats_.delivered;
  }
}

}  // namespace ridgeline::swarm
