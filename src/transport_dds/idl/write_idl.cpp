// ridgeline-idl-writer FILE: writes Ridgeline's DDS IDL (idl_writer.hpp) to FILE, for the build
// to compile with idlc. Writes a temporary file and renames it, so an interrupted build never
// leaves a half-written IDL behind.
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include "transport_dds/idl_writer.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: ridgeline-idl-writer FILE.idl\n");
    return 2;
  }
  try {
    const std::string path = argv[1];
    const std::string temporary = path + ".tmp";
    {
      std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
      out << ridgeline::transport_dds::ridgeline_idl();
      if (!out.flush()) {
        std::fprintf(stderr, "ridgeline-idl-writer: cannot write %s\n", temporary.c_str());
        return 1;
      }
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
      std::fprintf(stderr, "ridgeline-idl-writer: cannot rename %s to %s\n", temporary.c_str(),
                   path.c_str());
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ridgeline-idl-writer: %s\n", e.what());
    return 1;
  }
  return 0;
}
