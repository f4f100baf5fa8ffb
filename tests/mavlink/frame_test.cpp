// MAVLink v2 framing (src/mavlink/frame.*, messages.*): known-answer frames from an
// independent encoder, the checksum's catalogue value, truncation, and every rejection.
#include "mavlink/frame.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "core/error.hpp"
#include "mavlink/messages.hpp"
#include "mavlink/x25_crc.hpp"
#include "mavlink_test_support.hpp"

namespace ridgeline::mavlink {
namespace {

using testing::from_hex;
using testing::to_hex;


// The CRC catalogue's check value of CRC-16/MCRF4XX: the checksum of "123456789".
TEST(X25Crc, MatchesTheCatalogueCheckValue) {
  EXPECT_EQ(x25_accumulate(std::string_view("123456789"), kX25InitialValue), 0x6F91);
  const std::string s = "123456789";
  EXPECT_EQ(testing::reference_crc({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}),
            0x6F91);
}

// The field tables reproduce the published CRC_EXTRA and lengths (also static_asserted).
TEST(MessageSpecs, AgreeWithThePublishedDefinitions) {
  for (const auto& [id, published] : testing::published_specs()) {
    const MessageSpec* spec = find_message_spec(id);
    ASSERT_NE(spec, nullptr) << id;
    EXPECT_EQ(spec->crc_extra, published.crc_extra) << spec->name;
    EXPECT_EQ(spec->payload_size, published.length) << spec->name;
  }
  EXPECT_EQ(find_message_spec(1), nullptr);
  EXPECT_EQ(find_message_spec(0xFFFFFF), nullptr);
}

// Frames written by node-mavlink 2.3.0 (mavlink-mappings 1.0.21) for the same messages:
// our encoder must produce them byte for byte, and our decoder must read them back.
struct KnownAnswer {
  Message message;
  FrameHeader header;
  std::string hex;
};

std::vector<KnownAnswer> known_answers() {
  Heartbeat hb{393216, 13, 12, 129, 4, 3};
  SetPositionTargetLocalNed sp;
  sp.time_boot_ms = 12345;
  sp.vx = 8.5f;
  sp.vy = -2.25f;
  sp.vz = -1.0f;
  sp.yaw_rate = 0.125f;
  sp.type_mask = 1479;
  sp.target_system = 1;
  sp.target_component = 1;
  sp.coordinate_frame = 1;
  CommandLong arm;
  arm.param1 = 1.0f;
  arm.command = 400;
  arm.target_system = 1;
  arm.target_component = 1;
  LocalPositionNed lp{1000, 10.0f, -20.5f, -100.0f, 0.0f, 10.0f, 0.0f};
  Attitude at{1000, 0.0f, 0.5f, 1.5f, 0.0f, 0.0f, -0.25f};
  return {
      {hb, {7, 1, 1, 0}, "fd090000070101000000000006000d0c810403181e"},
      {sp, {42, 1, 191, 0},
       "fd3500002a01bf5400003930000000000000000000000000000000000841000010c0000080bf0000000000"
       "00000000000000000000000000003ec705010101bb3c"},
      // confirmation = 0 is truncated: 32 bytes on the wire instead of 33.
      {arm, {3, 1, 191, 0},
       "fd2000000301bf4c00000000803f00000000000000000000000000000000000000000000000090010101b68e"},
      // vz = 0 at the end: 24 bytes instead of 28.
      {lp, {200, 1, 1, 0}, "fd180000c80101200000e8030000000020410000a4c10000c8c20000000000002041dd43"},
      {at, {201, 1, 1, 0},
       "fd1c0000c901011e0000e8030000000000000000003f0000c03f0000000000000000000080be0399"},
  };
}

TEST(FrameEncoding, ReproducesTheIndependentEncodersFramesByteForByte) {
  for (const KnownAnswer& k : known_answers()) {
    const EncodedFrame f = encode_message(k.message, k.header);
    EXPECT_EQ(to_hex(f.view()), k.hex) << message_name(k.message);
  }
}

TEST(FrameDecoding, ReadsTheIndependentEncodersFrames) {
  for (const KnownAnswer& k : known_answers()) {
    const std::vector<std::uint8_t> bytes = from_hex(k.hex);
    Frame frame;
    const DecodeResult r = decode_frame(bytes, frame);
    ASSERT_EQ(r.status, FrameStatus::kOk) << message_name(k.message) << ": " << to_string(r.status);
    EXPECT_EQ(r.frame_size, bytes.size());
    EXPECT_EQ(frame.sequence, k.header.sequence);
    EXPECT_EQ(frame.system_id, k.header.system_id);
    EXPECT_EQ(frame.component_id, k.header.component_id);
    const std::optional<Message> m = decode_message(frame);
    ASSERT_TRUE(m.has_value());
    EXPECT_TRUE(*m == k.message) << message_name(k.message);
  }
}

// node-mavlink sends an all-zero payload with length 0; MAVLink's rule keeps one byte. Both
// must decode; ours sends one byte.
TEST(FrameTruncation, AllZeroPayloadKeepsOneByteAndAZeroLengthFrameIsAccepted) {
  const EncodedFrame ours = encode_message(Heartbeat{0, 0, 0, 0, 0, 0}, {0, 1, 1, 0});
  EXPECT_EQ(ours.size, kHeaderSize + 1 + kChecksumSize);
  EXPECT_EQ(ours.bytes[1], 1);
  const std::vector<std::uint8_t> node_frame = from_hex("fd0000000001010000007981");
  Frame f;
  ASSERT_EQ(decode_frame(node_frame, f).status, FrameStatus::kOk);
  EXPECT_EQ(f.wire_payload_size, 0);
  EXPECT_TRUE(decode_message(f) == Message(Heartbeat{0, 0, 0, 0, 0, 0}));
}

// Every message, every number of trailing zero fields: the wire length is the position of the
// last non-zero byte, and decoding zero-extends back to the original.
TEST(FrameTruncation, WireLengthEndsAtTheLastNonZeroByteAndDecodingRestoresTheMessage) {
  std::mt19937_64 rng(17);
  for (int i = 0; i < 20000; ++i) {
    const Message m = testing::random_any_message(rng, true);
    const EncodedFrame f = encode_message(m, testing::random_header(rng));
    const MessageSpec* spec = find_message_spec(f.bytes[7]);
    ASSERT_NE(spec, nullptr);
    std::size_t last_nonzero = 0;
    std::visit(
        [&](const auto& msg) {
          const auto payload = encode_payload(msg);
          for (std::size_t k = 0; k < payload.size(); ++k)
            if (payload[k] != 0) last_nonzero = k + 1;
        },
        m);
    ASSERT_EQ(f.bytes[1], std::max<std::size_t>(1, last_nonzero));
    Frame frame;
    ASSERT_EQ(decode_frame(f.view(), frame).status, FrameStatus::kOk);
    // Compare payload bytes (NaN fields make == on the structs false).
    std::visit(
        [&](const auto& msg) {
          using M = std::decay_t<decltype(msg)>;
          const auto back = decode_payload<M>(frame.payload);
          ASSERT_EQ(encode_payload(back), encode_payload(msg));
        },
        m);
  }
}

EncodedFrame with_checksum(std::vector<std::uint8_t> frame_without_crc, std::uint8_t crc_extra) {
  std::uint16_t crc = testing::reference_crc({frame_without_crc.data() + 1, frame_without_crc.size() - 1});
  crc = testing::reference_crc(std::span<const std::uint8_t>(&crc_extra, 1), crc);
  frame_without_crc.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  frame_without_crc.push_back(static_cast<std::uint8_t>(crc >> 8));
  EncodedFrame f;
  std::copy(frame_without_crc.begin(), frame_without_crc.end(), f.bytes.begin());
  f.size = frame_without_crc.size();
  return f;
}

TEST(FrameDecoding, RejectsEachKindOfBadFrameWithItsReason) {
  Frame frame;
  // A payload longer than the message (HEARTBEAT is 9 bytes), with a correct checksum.
  std::vector<std::uint8_t> long_hb(kHeaderSize + 10, 0x11);
  const std::uint8_t long_header[] = {0xFD, 10, 0, 0, 0, 1, 1, 0, 0, 0};
  std::copy(std::begin(long_header), std::end(long_header), long_hb.begin());
  EXPECT_EQ(decode_frame(with_checksum(long_hb, 50).view(), frame).status, FrameStatus::kBadLength);
  // An id nobody here knows (1 = SYS_STATUS).
  std::vector<std::uint8_t> unknown = {0xFD, 1, 0, 0, 0, 1, 1, 1, 0, 0, 5};
  EXPECT_EQ(decode_frame(with_checksum(unknown, 124).view(), frame).status,
            FrameStatus::kUnknownMessage);
  // A valid HEARTBEAT, then signed (flag 0x01, checksum recomputed, 13 signature bytes).
  std::vector<std::uint8_t> hb = {0xFD, 9, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 6, 0, 13, 12, 129, 4, 3};
  ASSERT_EQ(decode_frame(with_checksum(hb, 50).view(), frame).status, FrameStatus::kOk);
  std::vector<std::uint8_t> signed_hb = hb;
  signed_hb[2] = kIncompatFlagSigned;
  EncodedFrame s = with_checksum(signed_hb, 50);
  s.size += kSignatureSize;  // the signature bytes are zeros: never verified
  const DecodeResult rs = decode_frame(s.view(), frame);
  EXPECT_EQ(rs.status, FrameStatus::kSignedUnsupported);
  EXPECT_EQ(rs.frame_size, s.size);
  // An incompatibility flag nobody defined.
  std::vector<std::uint8_t> flagged = hb;
  flagged[2] = 0x02;
  EXPECT_EQ(decode_frame(with_checksum(flagged, 50).view(), frame).status,
            FrameStatus::kUnsupportedIncompatFlags);
  // The right frame seeded with the wrong CRC_EXTRA (a sender with another definition).
  EXPECT_EQ(decode_frame(with_checksum(hb, 51).view(), frame).status, FrameStatus::kBadChecksum);
  // Not a v2 frame.
  const std::vector<std::uint8_t> v1 = {0xFE, 9, 0, 1, 1, 0};
  EXPECT_EQ(decode_frame(v1, frame).status, FrameStatus::kBadStartByte);
  // Every proper prefix of a valid frame is incomplete, never accepted or misjudged.
  const EncodedFrame good = with_checksum(hb, 50);
  for (std::size_t n = 0; n < good.size; ++n)
    EXPECT_EQ(decode_frame(good.view().first(n), frame).status, FrameStatus::kIncomplete) << n;
}

// A single changed byte anywhere the checksum covers (other than the length, which moves the
// checksum, and the id, which changes the CRC_EXTRA too) is an error burst of ≤ 8 bits, which
// a 16-bit CRC always detects: every one of them must be rejected.
TEST(FrameDecoding, RejectsEverySingleByteCorruption) {
  std::mt19937_64 rng(3);
  int rejected = 0, tried = 0;
  for (int i = 0; i < 300; ++i) {
    const EncodedFrame f = encode_message(testing::random_any_message(rng, true), testing::random_header(rng));
    for (std::size_t pos = 2; pos < f.size; ++pos) {
      if (pos >= 7 && pos <= 9) continue;
      for (int delta = 1; delta < 256; delta += 37) {
        EncodedFrame g = f;
        g.bytes[pos] = static_cast<std::uint8_t>(g.bytes[pos] ^ delta);
        Frame frame;
        ++tried;
        if (decode_frame(g.view(), frame).status != FrameStatus::kOk) ++rejected;
      }
    }
  }
  EXPECT_EQ(rejected, tried);
}

TEST(FrameEncoding, RejectsUnknownIdsAndWrongPayloadSizesNamingTheField) {
  const std::array<std::uint8_t, 9> payload{};
  try {
    encode_frame({}, 1, payload);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "message_id");
    EXPECT_NE(std::string(e.what()).find("not a known message"), std::string::npos);
  }
  try {
    encode_frame({}, Attitude::kId, payload);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "payload");
    EXPECT_NE(std::string(e.what()).find("ATTITUDE needs 28 bytes, got 9"), std::string::npos);
  }
}

}  // namespace
}  // namespace ridgeline::mavlink
