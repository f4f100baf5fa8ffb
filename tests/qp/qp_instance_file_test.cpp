// The RLQP reader: a round trip of a hand-written file, and clear errors on garbled input.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "qp/qp_instance_file.hpp"

namespace ridgeline::qp {
namespace {

void put_int(std::string& out, std::int32_t v) {
  char b[4];
  std::memcpy(b, &v, 4);  // the test machine is little-endian like the format
  out.append(b, 4);
}
void put_doubles(std::string& out, std::initializer_list<double> values) {
  for (double v : values) {
    char b[8];
    std::memcpy(b, &v, 8);
    out.append(b, 8);
  }
}

// One instance: n = 2, m = 1; H row-major [[2, 1], [1, 3]], f = (1, −1), G = [1, 2],
// lg = −1, ug = 1e20 (no upper side), lb = (−1, −2), ub = (1, 2).
std::string one_instance_file() {
  std::string s = "RLQP";
  put_int(s, 1);
  put_int(s, 2);
  put_int(s, 1);
  put_doubles(s, {2, 1, 1, 3, 1, -1, 1, 2, -1, 1e20, -1, -2, 1, 2});
  return s;
}

TEST(QpInstanceFileTest, ParsesRowMajorArraysAndInfiniteSides) {
  const auto problems = parse_qp_instances(one_instance_file(), "mem.bin");
  ASSERT_EQ(problems.size(), 1u);
  const QpProblem& q = problems[0];
  EXPECT_EQ(q.H(0, 1), 1.0);
  EXPECT_EQ(q.H(1, 1), 3.0);
  EXPECT_EQ(q.f[1], -1.0);
  EXPECT_EQ(q.G(0, 1), 2.0);  // row-major G: second entry is column 1
  EXPECT_EQ(q.lg[0], -1.0);
  EXPECT_EQ(q.ug[0], kInfinity);
  EXPECT_EQ(q.lb[1], -2.0);
  EXPECT_EQ(q.ub[1], 2.0);
  EXPECT_EQ(q.A.rows(), 0);
}

std::string error_of(const std::string& bytes) {
  try {
    parse_qp_instances(bytes, "mpc.bin");
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "mpc.bin");
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(QpInstanceFileTest, TruncatedFileNamesInstanceAndByteOffset) {
  std::string bytes = one_instance_file();
  bytes.resize(bytes.size() - 5);
  const std::string msg = error_of(bytes);
  EXPECT_NE(msg.find("instance 0"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte offset 16"), std::string::npos) << msg;  // after magic, count, n, m
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
}

TEST(QpInstanceFileTest, GarbledInputIsRejectedWithAReason) {
  EXPECT_NE(error_of("QPRL").find("not an RLQP file"), std::string::npos);
  std::string negative = "RLQP";
  put_int(negative, 1);
  put_int(negative, -3);
  put_int(negative, 1);
  EXPECT_NE(error_of(negative).find("invalid variable count n = -3"), std::string::npos);
  std::string trailing = one_instance_file() + "x";
  EXPECT_NE(error_of(trailing).find("trailing bytes"), std::string::npos);
  std::string second_missing = one_instance_file();
  std::memcpy(&second_missing[4], "\x02\x00\x00\x00", 4);  // claims two instances
  const std::string msg = error_of(second_missing);
  EXPECT_NE(msg.find("instance 1"), std::string::npos) << msg;
}

TEST(QpInstanceFileTest, NanBoundIsRejectedNamingTheInstance) {
  std::string bytes = one_instance_file();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(&bytes[bytes.size() - 8], &nan, 8);  // ub[1]
  const std::string msg = error_of(bytes);
  EXPECT_NE(msg.find("instance 0"), std::string::npos) << msg;
  EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
}

// What `bench mpc --dump-qps` writes, the reader reads back bit for bit (infinite sides as
// ±1e20 in the file, ±kInfinity again after reading).
TEST(QpInstanceFileTest, WriterRoundTripsThroughTheReader) {
  const std::string path =
      ::testing::TempDir() + "qp_instance_writer_" + std::to_string(::getpid()) + ".bin";
  std::vector<QpProblem> written = parse_qp_instances(one_instance_file(), "mem.bin");
  QpProblem second = written[0];
  second.H(1, 1) = 5.0;
  second.lb[0] = -kInfinity;
  second.G.resize(0, 2);
  second.lg.resize(0);
  second.ug.resize(0);
  written.push_back(second);
  {
    QpInstanceWriter writer(path);
    for (const QpProblem& q : written) writer.write(q);
    writer.close();
    EXPECT_EQ(writer.count(), 2);
  }
  const std::vector<QpProblem> read = read_qp_instance_file(path);
  std::remove(path.c_str());
  ASSERT_EQ(read.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(read[k].H, written[k].H);
    EXPECT_EQ(read[k].f, written[k].f);
    EXPECT_EQ(read[k].G, written[k].G);
    EXPECT_EQ(read[k].lg, written[k].lg);
    EXPECT_EQ(read[k].ug, written[k].ug);
    EXPECT_EQ(read[k].lb, written[k].lb);
    EXPECT_EQ(read[k].ub, written[k].ub);
  }
  EXPECT_EQ(read[1].lb[0], -kInfinity);
}

TEST(QpInstanceFileTest, WriterRejectsEqualityRowsAndUnwritablePaths) {
  EXPECT_THROW(QpInstanceWriter("/nonexistent/dir/q.bin"), InputError);
  const std::string path =
      ::testing::TempDir() + "qp_instance_writer_eq_" + std::to_string(::getpid()) + ".bin";
  QpInstanceWriter writer(path);
  QpProblem q = parse_qp_instances(one_instance_file(), "mem.bin")[0];
  q.A = Eigen::RowVector2d(1.0, 1.0);
  q.b = Eigen::VectorXd::Constant(1, 0.0);
  try {
    writer.write(q);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), path);
    EXPECT_NE(std::string(e.what()).find("equality rows"), std::string::npos) << e.what();
  }
  writer.close();
  std::remove(path.c_str());
}

TEST(QpInstanceFileTest, MissingFileIsReported) {
  EXPECT_THROW(read_qp_instance_file("/nonexistent/mpc.bin"), InputError);
}

}  // namespace
}  // namespace ridgeline::qp
