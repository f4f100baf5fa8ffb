// The swarm's messages: defined once in messages/messages.hpp, named here in the swarm's
// namespace for the transports and agents.
#pragma once

#include "messages/messages.hpp"

namespace ridgeline::swarm {

using messages::check_message;
using messages::Envelope;
using messages::Message;
using messages::message_type_name;
using messages::PredictedTrajectory;
using messages::ReferencePlan;
using messages::StateReport;
using messages::ThreatReport;

}  // namespace ridgeline::swarm
