// The DDPG torch module (learning/ddpg_backend.hpp): this test program links no torch, loads
// libridgeline_ddpg.so from the build tree on first use, and a policy read through it acts;
// InputError thrown inside the module is caught here by its type.
#include "learning/ddpg_backend.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.hpp"
#include "learning/ddpg.hpp"

namespace ridgeline::learning {
namespace {

TEST(DdpgBackend, ModuleLoadsAndTheCommittedPolicyActs) {
  const std::string& path = ddpg_backend::module_path();
  EXPECT_EQ(std::filesystem::path(path).filename(), ddpg_backend::kModuleFileName);
  EXPECT_TRUE(std::filesystem::exists(path)) << path;

  const DdpgPolicy policy =
      DdpgPolicy::load(std::string(RIDGELINE_SOURCE_DIR) + "/models/ddpg_mountain.pt");
  EXPECT_GT(policy.action_period_s(), 0.0);
  Observation o{};
  o[3] = 1.0f;  // the target straight ahead
  const Vec3 a = policy.act(o);
  EXPECT_TRUE(a.allFinite());
  EXPECT_LE(a.cwiseAbs().maxCoeff(), 1.0);  // tanh output
  EXPECT_EQ(policy.act(o), a);              // deterministic: no noise, one thread
}

TEST(DdpgBackend, ModulesInputErrorIsCaughtByItsType) {
  try {
    DdpgPolicy::deserialize("not a torch archive", "bytes.pt");
    FAIL() << "no error";
  } catch (const InputError& e) {  // thrown in the module, caught in this program
    EXPECT_EQ(e.field(), "bytes.pt");
    EXPECT_NE(e.reason().find("not a readable DDPG model"), std::string::npos) << e.what();
  }
  DdpgOptions o;
  o.batch_size = 0;
  EXPECT_THROW(DdpgTrainer(o, task_environment(TrainingTask::kFlat)), InputError);
}

}  // namespace
}  // namespace ridgeline::learning
