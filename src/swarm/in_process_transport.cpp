#include "swarm/in_process_transport.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::swarm {

InProcessTransport::InProcessTransport(int num_participants, const LinkModel& link,
                                       std::uint64_t seed, const PredictionReach& reach)
    : num_participants_(num_participants), link_(link), reach_(reach), rng_(seed) {
  if (num_participants < 1) throw InputError("transport", "needs at least one participant");
  if (!(std::isfinite(link.latency_s) && link.latency_s >= 0.0))
    throw InputError("link.latency_s", fmt::format("must be >= 0, got {}", link.latency_s));
  if (!(std::isfinite(link.jitter_s) && link.jitter_s >= 0.0))
    throw InputError("link.jitter_s", fmt::format("must be >= 0, got {}", link.jitter_s));
  if (!(link.drop_rate >= 0.0 && link.drop_rate <= 1.0))
    throw InputError("link.drop_rate", fmt::format("must be in [0, 1], got {}", link.drop_rate));
  if (!(reach.reach_m > 0.0))
    throw InputError("reach.reach_m", fmt::format("must be > 0, got {}", reach.reach_m));
  if (!(std::isfinite(reach.far_period_s) && reach.far_period_s > 0.0))
    throw InputError("reach.far_period_s", fmt::format("must be > 0, got {}", reach.far_period_s));
  inboxes_.resize(static_cast<std::size_t>(num_participants));
  positions_.resize(static_cast<std::size_t>(num_participants));
  // Each sender on its own phase: the far copies spread over the period.
  for (int i = 0; i < num_participants; ++i)
    next_far_s_.push_back(reach.far_period_s * i / num_participants);
}

std::int64_t InProcessTransport::cell_key(const Vec3& p) const {
  const auto cx = static_cast<std::int64_t>(std::floor(p.x() / reach_.reach_m));
  const auto cy = static_cast<std::int64_t>(std::floor(p.y() / reach_.reach_m));
  return (cx << 32) ^ (cy & 0xffffffff);
}

void InProcessTransport::rebuild_grid() {
  for (auto& [key, members] : grid_) members.clear();
  unplaced_.clear();
  for (int i = 0; i < num_participants_; ++i) {
    if (const auto& p = positions_[static_cast<std::size_t>(i)]) {
      grid_[cell_key(*p)].push_back(i);
    } else {
      unplaced_.push_back(i);
    }
  }
}

void InProcessTransport::publish(int sender, double now_s, std::shared_ptr<const Message> shared) {
  if (shared == nullptr) throw InputError("message", "is null");
  ++stats_.published;
  const auto* prediction = std::get_if<PredictedTrajectory>(shared.get());
  bool by_reach = prediction != nullptr && std::isfinite(reach_.reach_m) &&
                  !prediction->positions_m.empty() && sender >= 0 && sender < num_participants_;
  if (by_reach) {
    if (now_s > grid_time_s_) {  // a new broadcast period: the grid from the last positions
      rebuild_grid();
      grid_time_s_ = now_s;
    }
    const Vec3 p = prediction->positions_m.front();
    positions_[static_cast<std::size_t>(sender)] = p;
    double& next_far_s = next_far_s_[static_cast<std::size_t>(sender)];
    if (now_s >= next_far_s) {
      next_far_s = now_s + reach_.far_period_s;
      by_reach = false;  // this one to everyone
    } else {
      // The 3 × 3 cells around the sender (cells are reach_m wide), then the distance itself,
      // and those without a position; in participant order, as a broadcast, so the random
      // draws (and so a run) do not depend on the grid's order.
      near_.assign(unplaced_.begin(), unplaced_.end());
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy) {
          const auto it = grid_.find(cell_key(p + Vec3(dx * reach_.reach_m, dy * reach_.reach_m, 0.0)));
          if (it == grid_.end()) continue;
          for (int r : it->second)
            if ((*positions_[static_cast<std::size_t>(r)] - p).norm() <= reach_.reach_m)
              near_.push_back(r);
        }
      std::sort(near_.begin(), near_.end());
    }
  }
  const int count = by_reach ? static_cast<int>(near_.size()) : num_participants_;
  for (int c = 0; c < count; ++c) {
    const int receiver = by_reach ? near_[static_cast<std::size_t>(c)] : c;
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
    out.emplace_back(p.sender, p.sent_s, p.delivered_s, p.message);
    inbox.pop();
    ++stats_.delivered;
  }
}

}  // namespace ridgeline::swarm
