#include "qp/qp_instance_file.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace ridgeline::qp {

namespace {

// Instance sizes beyond this are taken as garbage rather than allocated.
constexpr std::int32_t kMaxDimension = 100000;
constexpr double kFileInfinity = 1e20;

class Reader {
 public:
  Reader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  [[noreturn]] void fail(const std::string& where, const std::string& reason) const {
    throw InputError(name_, where + " at byte offset " + std::to_string(offset_) + ": " + reason);
  }

  std::int32_t int32(const std::string& where, const char* what) {
    need(4, where, what);
    std::uint32_t u = 0;
    for (int i = 0; i < 4; ++i) {
      u |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes_[offset_ + i])) << (8 * i);
    }
    offset_ += 4;
    std::int32_t v;
    std::memcpy(&v, &u, sizeof v);
    return v;
  }

  // Reads count little-endian float64 values into out.
  void doubles(const std::string& where, const char* what, double* out, std::size_t count) {
    need(8 * count, where, what);
    for (std::size_t k = 0; k < count; ++k) {
      std::uint64_t u = 0;
      for (int i = 0; i < 8; ++i) {
        u |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes_[offset_ + i]))
             << (8 * i);
      }
      std::memcpy(&out[k], &u, sizeof u);
      offset_ += 8;
    }
  }

  std::size_t offset() const { return offset_; }
  std::size_t remaining() const { return bytes_.size() - offset_; }

 private:
  void need(std::size_t count, const std::string& where, const char* what) const {
    if (remaining() < count) {
      fail(where, std::string("truncated: ") + what + " needs " + std::to_string(count) +
                      " bytes, " + std::to_string(remaining()) + " left");
    }
  }

  std::string_view bytes_;
  std::string name_;
  std::size_t offset_ = 0;
};

void read_matrix(Reader& r, const std::string& where, const char* what, Eigen::MatrixXd& out,
                 int rows, int cols) {
  // The file is row-major; a row-major map of a column-major buffer is its transpose.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> tmp(rows, cols);
  r.doubles(where, what, tmp.data(), static_cast<std::size_t>(rows) * cols);
  out = tmp;
}

void read_vector(Reader& r, const std::string& where, const char* what, Eigen::VectorXd& out,
                 int size) {
  out.resize(size);
  r.doubles(where, what, out.data(), static_cast<std::size_t>(size));
}

void check_finite(const Reader& r, const std::string& where, const char* what,
                  const Eigen::MatrixXd& x) {
  if (!x.allFinite()) r.fail(where, std::string(what) + " contains NaN or infinity");
}

void to_infinity(Eigen::VectorXd& v) {
  for (double& x : v) {
    if (x >= kFileInfinity) x = kInfinity;
    if (x <= -kFileInfinity) x = -kInfinity;
  }
}

}  // namespace

std::vector<QpProblem> parse_qp_instances(std::string_view bytes, const std::string& name) {
  Reader in(bytes, name);
  if (bytes.size() < 4 || bytes.substr(0, 4) != "RLQP") {
    in.fail("header", "not an RLQP file (the first 4 bytes must be \"RLQP\")");
  }
  in.int32("header", "magic");
  const std::int32_t count = in.int32("header", "instance count");
  if (count < 0) in.fail("header", "negative instance count " + std::to_string(count));
  std::vector<QpProblem> out;
  out.reserve(static_cast<std::size_t>(std::min<std::int32_t>(count, 100000)));
  for (std::int32_t k = 0; k < count; ++k) {
    const std::string where = "instance " + std::to_string(k);
    const std::int32_t n = in.int32(where, "n");
    const std::int32_t m = in.int32(where, "m");
    if (n <= 0 || n > kMaxDimension) in.fail(where, "invalid variable count n = " + std::to_string(n));
    if (m < 0 || m > kMaxDimension) in.fail(where, "invalid row count m = " + std::to_string(m));
    const std::size_t needed =
        8 * (static_cast<std::size_t>(n) * n + 3 * static_cast<std::size_t>(n) +
             static_cast<std::size_t>(m) * n + 2 * static_cast<std::size_t>(m));
    if (in.remaining() < needed) {
      in.fail(where, "truncated: n = " + std::to_string(n) + ", m = " + std::to_string(m) +
                         " need " + std::to_string(needed) + " bytes, " +
                         std::to_string(in.remaining()) + " left");
    }
    QpProblem q;
    read_matrix(in, where, "H", q.H, n, n);
    read_vector(in, where, "f", q.f, n);
    read_matrix(in, where, "G", q.G, m, n);
    read_vector(in, where, "lg", q.lg, m);
    read_vector(in, where, "ug", q.ug, m);
    read_vector(in, where, "lb", q.lb, n);
    read_vector(in, where, "ub", q.ub, n);
    check_finite(in, where, "H", q.H);
    check_finite(in, where, "f", q.f);
    check_finite(in, where, "G", q.G);
    for (auto* v : {&q.lg, &q.ug, &q.lb, &q.ub}) {
      for (double x : *v) {
        if (std::isnan(x)) in.fail(where, "a bound is NaN");
      }
      to_infinity(*v);
    }
    out.push_back(std::move(q));
  }
  if (in.remaining() != 0) {
    in.fail("end of file", std::to_string(in.remaining()) + " trailing bytes after " +
                               std::to_string(count) + " instances");
  }
  return out;
}

std::vector<QpProblem> read_qp_instance_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path, "cannot open QP instance file");
  std::ostringstream buffer;
  buffer << file.rdbuf();
  const std::string bytes = buffer.str();
  return parse_qp_instances(bytes, path);
}

namespace {

void put_int32(std::ofstream& out, std::int32_t v) {
  std::uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  char b[4];
  for (int i = 0; i < 4; ++i) b[i] = static_cast<char>((u >> (8 * i)) & 0xffu);
  out.write(b, 4);
}

void put_double(std::ofstream& out, double v) {
  if (v >= kFileInfinity) v = kFileInfinity;
  if (v <= -kFileInfinity) v = -kFileInfinity;
  std::uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  char b[8];
  for (int i = 0; i < 8; ++i) b[i] = static_cast<char>((u >> (8 * i)) & 0xffu);
  out.write(b, 8);
}

// Row-major, as the format stores matrices.
void put_matrix(std::ofstream& out, const Eigen::MatrixXd& a) {
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) put_double(out, a(i, j));
  }
}

void put_vector(std::ofstream& out, const Eigen::VectorXd& v, Eigen::Index size, double absent) {
  for (Eigen::Index i = 0; i < size; ++i) put_double(out, v.size() != 0 ? v[i] : absent);
}

}  // namespace

QpInstanceWriter::QpInstanceWriter(const std::string& path)
    : file_(path, std::ios::binary | std::ios::trunc), path_(path) {
  if (!file_) throw InputError(path, "cannot create QP instance file");
  file_.write("RLQP", 4);
  put_int32(file_, 0);
}

QpInstanceWriter::~QpInstanceWriter() {
  if (closed_) return;
  try {
    close();
  } catch (const InputError&) {
    // A destructor must not throw; a caller that cares calls close().
  }
}

void QpInstanceWriter::write(const QpProblem& q) {
  if (closed_) throw InputError(path_, "write after close");
  if (q.A.rows() != 0) {
    throw InputError(path_, "instance " + std::to_string(count_) + " has " +
                                std::to_string(q.A.rows()) +
                                " equality rows, which the RLQP format cannot hold");
  }
  const Eigen::Index n = q.H.rows(), m = q.G.rows();
  put_int32(file_, static_cast<std::int32_t>(n));
  put_int32(file_, static_cast<std::int32_t>(m));
  put_matrix(file_, q.H);
  put_vector(file_, q.f, n, 0.0);
  put_matrix(file_, q.G);
  put_vector(file_, q.lg, m, -kFileInfinity);
  put_vector(file_, q.ug, m, kFileInfinity);
  put_vector(file_, q.lb, n, -kFileInfinity);
  put_vector(file_, q.ub, n, kFileInfinity);
  if (!file_) throw InputError(path_, "write failed at instance " + std::to_string(count_));
  ++count_;
}

void QpInstanceWriter::close() {
  if (closed_) return;
  closed_ = true;
  file_.seekp(4);
  put_int32(file_, count_);
  file_.close();
  if (!file_) throw InputError(path_, "write failed while closing");
}

}  // namespace ridgeline::qp
