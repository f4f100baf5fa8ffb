// Our MAVLink against an independent implementation: the npm packages node-mavlink and
// mavlink-mappings (tools/mavlink-check, installed by `make test`), which share no code with
// src/mavlink. For every message we use, node-mavlink decodes frames we encode (its splitter
// checks each checksum with the message's CRC_EXTRA, so a frame it accepts has our CRC_EXTRA
// and length right) and encodes frames we decode, field by field, truncated payloads included.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "mavlink/frame.hpp"
#include "mavlink/messages.hpp"
#include "mavlink_test_support.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::mavlink {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kToolDir = fs::path(RIDGELINE_SOURCE_DIR) / "tools" / "mavlink-check";

template <class M>
json fields_json(const M& m) {
  json j = json::object();
  std::apply([&](const auto&... f) { ((j[std::string(f.name)] = m.*(f.member)), ...); }, M::fields);
  return j;
}

/// Field by field: every field of `m` equals node-mavlink's value for it (floats exactly: a
/// float converts to a double and back without loss, and JSON carries doubles exactly).
template <class M>
::testing::AssertionResult fields_equal(const M& m, const json& node_fields) {
  ::testing::AssertionResult result = ::testing::AssertionSuccess();
  bool ok = true;
  std::apply(
      [&](const auto&... f) {
        (([&] {
           using T = std::remove_cvref_t<decltype(m.*(f.member))>;
           const std::string name(f.name);
           if (!node_fields.contains(name) || !node_fields[name].is_number()) {
             if (ok) result = ::testing::AssertionFailure();
             ok = false;
             result << M::kName << "." << name << " missing in node-mavlink's output; ";
             return;
           }
           const T theirs = static_cast<T>(node_fields[name].template get<double>());
           if (!(theirs == m.*(f.member))) {
             if (ok) result = ::testing::AssertionFailure();
             ok = false;
             result << M::kName << "." << name << ": ours " << +(m.*(f.member)) << ", node-mavlink "
                    << +theirs << "; ";
           }
         }()),
         ...);
      },
      M::fields);
  return result;
}

int run_node(const fs::path& in, const fs::path& out, const fs::path& log) {
  const std::string cmd = "node " + (kToolDir / "check.js").string() + " " + in.string() + " " +
                          out.string() + " >" + log.string() + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Case {
  Message message;
  FrameHeader header;
  EncodedFrame ours;
};

TEST(NodeMavlinkCrossCheck, AgreesFieldByFieldInBothDirectionsForEveryMessage) {
  ASSERT_TRUE(fs::exists(kToolDir / "node_modules" / "node-mavlink" / "package.json"))
      << "node-mavlink is not installed: run `npm ci --prefix tools/mavlink-check` (make test "
         "does it)";
  const fs::path dir = testing_support::fresh_test_dir();
  std::mt19937_64 rng(76);
  std::vector<Case> cases;
  constexpr int kPerMessage = 200;
  for (int i = 0; i < 5 * kPerMessage; ++i) {
    Message m;
    switch (i % 5) {
      case 0: m = testing::random_message<Heartbeat>(rng, false); break;
      case 1: m = testing::random_message<Attitude>(rng, false); break;
      case 2: m = testing::random_message<LocalPositionNed>(rng, false); break;
      case 3: m = testing::random_message<CommandLong>(rng, false); break;
      default: m = testing::random_message<SetPositionTargetLocalNed>(rng, false); break;
    }
    const FrameHeader h = testing::random_header(rng);
    cases.push_back({m, h, encode_message(m, h)});
  }
  json in;
  in["decode"] = json::array();
  in["encode"] = json::array();
  for (const Case& c : cases) {
    in["decode"].push_back(testing::to_hex(c.ours.view()));
    in["encode"].push_back({{"msgid", c.ours.bytes[7]},
                            {"seq", c.header.sequence},
                            {"sysid", c.header.system_id},
                            {"compid", c.header.component_id},
                            {"fields", std::visit([](const auto& m) { return fields_json(m); },
                                                  c.message)}});
  }
  // Control: each message's frame checksummed with a wrong CRC_EXTRA, as a sender with another
  // definition of the message would send it. node-mavlink must drop all five, which shows its
  // acceptance of ours above is a real check of our CRC_EXTRA values.
  for (int k = 0; k < 5; ++k) {
    EncodedFrame bad = cases[static_cast<std::size_t>(k)].ours;
    const std::size_t n = bad.bytes[1];
    std::uint16_t crc = testing::reference_crc({bad.bytes.data() + 1, kHeaderSize - 1 + n});
    const std::uint8_t wrong_extra =
        static_cast<std::uint8_t>(find_message_spec(bad.bytes[7])->crc_extra + 1);
    crc = testing::reference_crc(std::span<const std::uint8_t>(&wrong_extra, 1), crc);
    bad.bytes[kHeaderSize + n] = static_cast<std::uint8_t>(crc & 0xFF);
    bad.bytes[kHeaderSize + n + 1] = static_cast<std::uint8_t>(crc >> 8);
    in["decode"].push_back(testing::to_hex(bad.view()));
  }
  std::ofstream(dir / "in.json") << in.dump();
  ASSERT_EQ(run_node(dir / "in.json", dir / "out.json", dir / "node.log"), 0)
      << std::ifstream(dir / "node.log").rdbuf();
  const json out = json::parse(std::ifstream(dir / "out.json"));

  // node-mavlink decodes our frames.
  const json& decoded = out["decoded"];
  ASSERT_EQ(decoded.size(), cases.size()) << "node-mavlink dropped some of our frames";
  EXPECT_EQ(out["invalid"].get<int>(), 5) << "the wrong-CRC_EXTRA frames were not all dropped";
  int truncated = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Case& c = cases[i];
    const json& d = decoded[i];
    EXPECT_EQ(d["msgid"].get<int>(), c.ours.bytes[7]);
    EXPECT_EQ(d["seq"].get<int>(), c.header.sequence);
    EXPECT_EQ(d["sysid"].get<int>(), c.header.system_id);
    EXPECT_EQ(d["compid"].get<int>(), c.header.component_id);
    EXPECT_EQ(d["payload_length"].get<int>(), c.ours.bytes[1]);
    if (c.ours.bytes[1] < find_message_spec(c.ours.bytes[7])->payload_size) ++truncated;
    std::visit([&](const auto& m) { EXPECT_TRUE(fields_equal(m, d["fields"])) << "frame " << i; },
               c.message);
  }

  // We decode node-mavlink's frames, and they are byte for byte ours (except an all-zero
  // payload, which node-mavlink truncates to nothing and MAVLink's rule to one byte).
  const json& encoded = out["encoded"];
  ASSERT_EQ(encoded.size(), cases.size());
  int identical = 0, all_zero = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::vector<std::uint8_t> theirs = testing::from_hex(encoded[i].get<std::string>());
    Frame frame;
    const DecodeResult r = decode_frame(theirs, frame);
    ASSERT_EQ(r.status, FrameStatus::kOk) << "frame " << i << ": " << to_string(r.status);
    EXPECT_EQ(r.frame_size, theirs.size());
    EXPECT_EQ(frame.sequence, cases[i].header.sequence);
    EXPECT_EQ(frame.system_id, cases[i].header.system_id);
    EXPECT_EQ(frame.component_id, cases[i].header.component_id);
    const std::optional<Message> back = decode_message(frame);
    ASSERT_TRUE(back.has_value());
    EXPECT_TRUE(*back == cases[i].message) << "frame " << i << " " << message_name(*back);
    if (testing::to_hex(cases[i].ours.view()) == encoded[i].get<std::string>()) ++identical;
    else if (theirs[1] == 0 && cases[i].ours.bytes[1] == 1 && cases[i].ours.bytes[kHeaderSize] == 0)
      ++all_zero;
  }
  EXPECT_EQ(identical + all_zero, static_cast<int>(cases.size()));
  EXPECT_GT(truncated, static_cast<int>(cases.size()) / 10);  // truncation really exercised
  std::printf("node-mavlink %s (mavlink-mappings %s): %zu of our frames decoded field by field "
              "(%d truncated), %zu of its frames decoded by us, %d byte-identical, %d all-zero\n",
              out["versions"]["node-mavlink"].get<std::string>().c_str(),
              out["versions"]["mavlink-mappings"].get<std::string>().c_str(), decoded.size(),
              truncated, encoded.size(), identical, all_zero);
}

}  // namespace
}  // namespace ridgeline::mavlink
