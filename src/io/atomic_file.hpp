// Writing output files so that nothing half-written is ever left behind.
#pragma once

#include <filesystem>
#include <string_view>

namespace ridgeline::io {

/// Writes `content` to `path` through a temporary file in the same folder and a rename, so
/// readers see either the old file or the complete new one. Creates missing parent folders.
/// Throws InputError naming the path when the folder or file cannot be written.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

}  // namespace ridgeline::io
