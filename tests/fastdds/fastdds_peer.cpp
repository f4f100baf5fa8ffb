// ridgeline-fastdds-peer: a second DDS implementation (eProsima Fast DDS, which ROS 2 and PX4's
// uXRCE-DDS agent are built on) reading and writing Ridgeline's topics, for
// tests/transport_dds/fastdds_crosscheck_test.cpp. Its types are fastddsgen's translation of
// the IDL Ridgeline generates from its message definitions (build/generated/idl/), so nothing
// here restates a message; it links no Ridgeline and no Cyclone DDS code.
//
//   ridgeline-fastdds-peer DOMAIN PARTITION TIMESTAMP_US PX PY PZ VX VY VZ AX AY AZ JX JY JZ YAW
//                          YAWSPEED
//
// On loopback (UDPv4 on 127.0.0.1 only, unicast discovery of participants 0..19, as Ridgeline's
// participants are configured) in DDS domain DOMAIN and partition PARTITION ("" = default), it
// subscribes to rt/ridgeline/predicted_trajectory and rt/ridgeline/threat_report and prints
// every sample's fields, one line a sample (doubles with 17 significant digits, so a printed
// value is the value received); meanwhile it publishes the TrajectorySetpoint of its arguments
// on rt/uav_1/fmu/in/trajectory_setpoint every 50 ms (best effort, volatile, as a companion
// writes to PX4). It exits 0 one second after it has printed both kinds, 1 after 20 s without.
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <string>
#include <thread>

#include "transport_dds/px4_msgsPubSubTypes.h"
#include "transport_dds/ridgeline_msgsPubSubTypes.h"

using namespace eprosima::fastdds::dds;

namespace {

void print_vector(const ridgeline::msg::dds_::Vector3_& v) {
  std::printf("(%.17g, %.17g, %.17g)", v.x(), v.y(), v.z());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 18) {
    std::fprintf(stderr,
                 "usage: ridgeline-fastdds-peer DOMAIN PARTITION TIMESTAMP_US PX PY PZ VX VY VZ AX "
                 "AY AZ JX JY JZ YAW YAWSPEED\n");
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const std::string partition = argv[2];
  px4_msgs::msg::dds_::TrajectorySetpoint_ setpoint;
  setpoint.timestamp(std::strtoull(argv[3], nullptr, 10));
  std::array<float, 3>* vectors[] = {&setpoint.position(), &setpoint.velocity(),
                                     &setpoint.acceleration(), &setpoint.jerk()};
  for (int v = 0; v < 4; ++v)
    for (int k = 0; k < 3; ++k) (*vectors[v])[k] = std::strtof(argv[4 + 3 * v + k], nullptr);
  setpoint.yaw(std::strtof(argv[16], nullptr));
  setpoint.yawspeed(std::strtof(argv[17], nullptr));

  DomainParticipantQos pqos;
  pqos.name("ridgeline-fastdds-peer");
  pqos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back("127.0.0.1");
  pqos.transport().user_transports.push_back(udp);
  // RTPS's well-known discovery ports of participants 0..19 on 127.0.0.1 (lo has no multicast).
  for (int id = 0; id < 20; ++id) {
    eprosima::fastrtps::rtps::Locator_t peer;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, 127, 0, 0, 1);
    peer.port = static_cast<std::uint32_t>(7400 + 250 * domain + 10 + 2 * id);
    pqos.wire_protocol().builtin.initialPeersList.push_back(peer);
  }
  DomainParticipant* participant =
      DomainParticipantFactory::get_instance()->create_participant(domain, pqos);
  if (participant == nullptr) {
    std::fprintf(stderr, "ridgeline-fastdds-peer: cannot create a participant\n");
    return 1;
  }
  TypeSupport prediction_type(new ridgeline::msg::dds_::PredictedTrajectory_PubSubType());
  TypeSupport threat_type(new ridgeline::msg::dds_::ThreatReport_PubSubType());
  TypeSupport setpoint_type(new px4_msgs::msg::dds_::TrajectorySetpoint_PubSubType());
  prediction_type.register_type(participant);
  threat_type.register_type(participant);
  setpoint_type.register_type(participant);
  Topic* prediction_topic = participant->create_topic(
      "rt/ridgeline/predicted_trajectory", prediction_type.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* threat_topic = participant->create_topic("rt/ridgeline/threat_report",
                                                  threat_type.get_type_name(), TOPIC_QOS_DEFAULT);
  Topic* setpoint_topic = participant->create_topic(
      "rt/uav_1/fmu/in/trajectory_setpoint", setpoint_type.get_type_name(), TOPIC_QOS_DEFAULT);

  SubscriberQos sqos = SUBSCRIBER_QOS_DEFAULT;
  PublisherQos wqos = PUBLISHER_QOS_DEFAULT;
  if (!partition.empty()) {
    sqos.partition().push_back(partition.c_str());
    wqos.partition().push_back(partition.c_str());
  }
  Subscriber* subscriber = participant->create_subscriber(sqos);
  Publisher* publisher = participant->create_publisher(wqos);
  // The readers' QoS must be what the topics offer (topics.hpp): a reliable reader would not
  // match the best-effort prediction writer.
  DataReaderQos prediction_qos = DATAREADER_QOS_DEFAULT;
  prediction_qos.reliability().kind = BEST_EFFORT_RELIABILITY_QOS;
  DataReaderQos threat_qos = DATAREADER_QOS_DEFAULT;
  threat_qos.reliability().kind = RELIABLE_RELIABILITY_QOS;
  threat_qos.history().depth = 16;
  DataReader* prediction_reader = subscriber->create_datareader(prediction_topic, prediction_qos);
  DataReader* threat_reader = subscriber->create_datareader(threat_topic, threat_qos);
  DataWriterQos setpoint_qos = DATAWRITER_QOS_DEFAULT;
  setpoint_qos.reliability().kind = BEST_EFFORT_RELIABILITY_QOS;
  setpoint_qos.durability().kind = VOLATILE_DURABILITY_QOS;
  DataWriter* setpoint_writer = publisher->create_datawriter(setpoint_topic, setpoint_qos);
  if (prediction_reader == nullptr || threat_reader == nullptr || setpoint_writer == nullptr) {
    std::fprintf(stderr, "ridgeline-fastdds-peer: cannot create the readers and the writer\n");
    return 1;
  }

  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  Clock::time_point both_seen{};
  bool have_prediction = false, have_threat = false;
  int rc = 1;
  while (Clock::now() - start < std::chrono::seconds(20)) {
    setpoint_writer->write(&setpoint);
    SampleInfo info;
    ridgeline::msg::dds_::PredictedTrajectory_ p;
    while (prediction_reader->take_next_sample(&p, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::printf("PredictedTrajectory uav=%d stamp_s=%.17g step_s=%.17g positions_m=[", p.uav(),
                  p.stamp_s(), p.step_s());
      for (std::size_t k = 0; k < p.positions_m().size(); ++k) {
        if (k > 0) std::printf(", ");
        print_vector(p.positions_m()[k]);
      }
      std::printf("]\n");
      have_prediction = true;
    }
    ridgeline::msg::dds_::ThreatReport_ t;
    while (threat_reader->take_next_sample(&t, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::printf("ThreatReport reporter=%d threat_id=%d stamp_s=%.17g centre_m=", t.reporter(),
                  t.threat_id(), t.stamp_s());
      print_vector(t.centre_m());
      std::printf(" velocity_m_s=");
      print_vector(t.velocity_m_s());
      std::printf(" radius_m=%.17g\n", t.radius_m());
      have_threat = true;
    }
    std::fflush(stdout);
    if (have_prediction && have_threat) {
      if (both_seen == Clock::time_point{}) both_seen = Clock::now();
      if (Clock::now() - both_seen > std::chrono::seconds(1)) {
        rc = 0;
        break;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (rc != 0)
    std::fprintf(stderr, "ridgeline-fastdds-peer: after 20 s: prediction %s, threat report %s\n",
                 have_prediction ? "received" : "NOT received",
                 have_threat ? "received" : "NOT received");
  participant->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant);
  return rc;
}
