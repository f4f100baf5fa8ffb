// libtorch is loaded only by what needs it (issue 17): neither the command line program nor
// any test program (this one links every layer) depends on libtorch or libc10, `ridgeline --help`
// loads no torch library, and the torch module, libridgeline_ddpg.so, does depend on them (so
// the check sees torch where it is). The dependencies are the loader's own list: `ldd`, which
// follows every shared library's DT_NEEDED entries.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace {

/// The command's standard output and error, and its exit status.
std::pair<std::string, int> capture(const std::string& command) {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  std::string out;
  if (!pipe) return {out, -1};
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe.get()) != nullptr) out += buffer.data();
  const int status = pclose(pipe.release());
  return {out, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

bool names_torch(const std::string& text) {
  return text.find("libtorch") != std::string::npos || text.find("libc10") != std::string::npos;
}

std::string ldd(const std::string& file) {
  const auto [out, status] = capture("ldd '" + file + "'");
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("libc.so"), std::string::npos) << out;  // ldd did list the libraries
  return out;
}

TEST(CliDependencies, TheProgramAndTheTestProgramsLinkNoTorch) {
  EXPECT_FALSE(names_torch(ldd(RIDGELINE_CLI_PATH))) << ldd(RIDGELINE_CLI_PATH);
  // This program and every other test program beside it, those of the learning layer included
  // (they load the module as the command line program does).
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  int checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator(self.parent_path())) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || !name.ends_with("_test")) continue;
    const std::string out = ldd(entry.path().string());
    EXPECT_FALSE(names_torch(out)) << name << ":\n" << out;
    ++checked;
  }
  EXPECT_GE(checked, 1);
}

TEST(CliDependencies, TheTorchModuleLinksTorch) {
  const std::string out = ldd(RIDGELINE_DDPG_MODULE_PATH);
  EXPECT_NE(out.find("libtorch_cpu"), std::string::npos) << out;
  EXPECT_NE(out.find("libc10"), std::string::npos) << out;
  EXPECT_EQ(out.find("not found"), std::string::npos) << out;
}

TEST(CliDependencies, TheAgentProgramLinksNeitherTheSimulatorNorTorch) {
  const std::string libraries = ldd(RIDGELINE_AGENT_PATH);
  EXPECT_FALSE(names_torch(libraries)) << libraries;
  // The layers are static libraries, so what was linked in shows in the program's symbols.
  const auto [symbols, status] = capture(std::string("nm -C '") + RIDGELINE_AGENT_PATH + "'");
  ASSERT_EQ(status, 0) << symbols;
  EXPECT_NE(symbols.find("ridgeline::nodes::run_agent_node"), std::string::npos);  // nm did list
  EXPECT_NE(symbols.find("ridgeline::mission::"), std::string::npos);
  for (const char* layer : {"ridgeline::sim::", "ridgeline::baselines::", "ridgeline::learning::",
                            "ridgeline::benchmarks::"})
    EXPECT_EQ(symbols.find(layer), std::string::npos) << layer;
  // ...whereas the command line program has them all (the check can see a layer).
  const auto [cli_symbols, cli_status] = capture(std::string("nm -C '") + RIDGELINE_CLI_PATH + "'");
  ASSERT_EQ(cli_status, 0);
  EXPECT_NE(cli_symbols.find("ridgeline::sim::"), std::string::npos);
  const auto [help, help_status] = capture(std::string(RIDGELINE_AGENT_PATH) + " --help");
  EXPECT_EQ(help_status, 0) << help;
  EXPECT_NE(help.find("--id"), std::string::npos) << help;
}

TEST(CliDependencies, HelpLoadsNoTorchLibrary) {
  // LD_DEBUG=libs logs every library the dynamic loader looks for, dlopen()ed ones included.
  const auto [out, status] =
      capture(std::string("LD_DEBUG=libs ") + RIDGELINE_CLI_PATH + " --help");
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("libstdc++"), std::string::npos) << out;  // the log was written
  EXPECT_FALSE(names_torch(out)) << out;
}

}  // namespace
