// ridgeline-idl-writer RIDGELINE.idl PX4_MSGS.idl: writes Ridgeline's DDS IDL and the px4_msgs
// IDL of PX4's topics (idl_writer.hpp) to the two files, for the build to compile with idlc.
// Writes a temporary file and renames it, so an interrupted build never leaves a half-written
// IDL behind.
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "transport_dds/idl_writer.hpp"

namespace {

/// Writes `text` to `path` through a temporary file; false (after a message) on failure.
bool write_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) {
      std::fprintf(stderr, "ridgeline-idl-writer: cannot write %s\n", temporary.c_str());
      return false;
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::fprintf(stderr, "ridgeline-idl-writer: cannot rename %s to %s\n", temporary.c_str(),
                 path.c_str());
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: ridgeline-idl-writer RIDGELINE.idl PX4_MSGS.idl\n");
    return 2;
  }
  try {
    if (!write_atomically(argv[1], ridgeline::transport_dds::ridgeline_idl())) return 1;
    if (!write_atomically(argv[2], ridgeline::transport_dds::px4_msgs_idl())) return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ridgeline-idl-writer: %s\n", e.what());
    return 1;
  }
  return 0;
}
