// Reader of QP instance files (`RLQP`), the format written by /work/shared/qp/gen_mpc_qps.py
// and read by `ridgeline bench qp`.
//
// Layout (little-endian): the 4 bytes "RLQP", int32 count, then per instance int32 n (> 0),
// int32 m (≥ 0) and float64 arrays H[n·n] (row-major), f[n], G[m·n] (row-major), lg[m], ug[m],
// lb[n], ub[n]. Sides with magnitude ≥ 1e20 mean "no bound" and become ±kInfinity.
#pragma once

#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "qp/qp_solver.hpp"

namespace ridgeline::qp {

/// Reads every instance of the file at `path`. Throws ridgeline::InputError naming the file,
/// the instance index and the byte offset when the file is missing, truncated or garbled.
std::vector<QpProblem> read_qp_instance_file(const std::string& path);

/// Parses the bytes of an instance file; `name` is used in error messages.
std::vector<QpProblem> parse_qp_instances(std::string_view bytes, const std::string& name);

/// Writes instances one at a time to an RLQP file (infinite sides as ±1e20); the instance
/// count in the header is filled in by close(). The format has no equality rows: write()
/// rejects a problem with rows in A.
class QpInstanceWriter {
 public:
  /// Throws ridgeline::InputError naming the file when it cannot be created.
  explicit QpInstanceWriter(const std::string& path);
  ~QpInstanceWriter();
  QpInstanceWriter(const QpInstanceWriter&) = delete;
  QpInstanceWriter& operator=(const QpInstanceWriter&) = delete;

  /// Appends `problem`; throws ridgeline::InputError when it has equality rows or on I/O error.
  void write(const QpProblem& problem);
  /// Writes the count and closes the file; throws ridgeline::InputError on I/O error.
  void close();
  int count() const { return count_; }

 private:
  std::ofstream file_;
  std::string path_;
  int count_ = 0;
  bool closed_ = false;
};

}  // namespace ridgeline::qp
