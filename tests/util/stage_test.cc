#include "mcvo/util/stage.h"

#include <new>
#include <stdexcept>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "mcvo/util/parallel.h"

namespace mcvo {
namespace {

TEST(Stage, NestsAndUnwinds) {
  EXPECT_EQ(CurrentStage(), "");
  {
    const ScopedStage run("run --out x");
    EXPECT_EQ(CurrentStage(), "run --out x");
    {
      const ScopedStage frame("frontend: frame 12");
      EXPECT_EQ(CurrentStage(), "run --out x: frontend: frame 12");
    }
    EXPECT_EQ(CurrentStage(), "run --out x");
    EXPECT_EQ(FailedStage(), "run --out x");  // no failure: the current stage
  }
  EXPECT_EQ(CurrentStage(), "");
}

TEST(Stage, AnExceptionLeavesTheInnermostStageItLeft) {
  try {
    const ScopedStage run("run");
    { const ScopedStage ok("odometry"); }
    const ScopedStage loops("loop closure");
    const ScopedStage query("query 3");
    throw std::bad_alloc();
  } catch (const std::bad_alloc&) {
    EXPECT_EQ(CurrentStage(), "");
    EXPECT_EQ(FailedStage(), "run: loop closure: query 3");
  }
  // Entering a stage (normal work again) forgets the failure.
  {
    const ScopedStage next("next");
    EXPECT_EQ(FailedStage(), "next");
  }
  EXPECT_EQ(FailedStage(), "");
}

TEST(Stage, AFailureCaughtInsideAStageIsForgottenWhenTheStageEndsNormally) {
  {
    const ScopedStage outer("outer");
    try {
      const ScopedStage inner("inner");
      throw std::runtime_error("handled");
    } catch (const std::runtime_error&) {
      EXPECT_EQ(FailedStage(), "outer: inner");
    }
  }
  EXPECT_EQ(FailedStage(), "");
}

TEST(Stage, AWorkersFailureNamesTheWorkersStageOnTheCaller) {
  try {
    const ScopedStage run("run --out r");
    const ScopedStage frame("frontend: frame 7");
    ParallelFor(4, 4, [](int camera) {
      // The worker runs inside the caller's stages.
      EXPECT_EQ(CurrentStage().rfind("run --out r: frontend: frame 7", 0), 0u) << CurrentStage();
      const ScopedStage stage("camera " + std::to_string(camera));
      if (camera == 2) throw std::bad_alloc();
    });
    ADD_FAILURE() << "no exception";
  } catch (const std::bad_alloc&) {
    EXPECT_EQ(FailedStage(), "run --out r: frontend: frame 7: camera 2");
  }
}

TEST(Stage, StagesArePerThread) {
  const ScopedStage main_stage("main");
  std::string seen = "unset";
  std::thread other([&] { seen = CurrentStage(); });
  other.join();
  EXPECT_EQ(seen, "");
  EXPECT_EQ(CurrentStage(), "main");
}

TEST(Stage, CapturedFailureRethrownElsewhere) {
  StagedFailure failure;
  std::thread worker([&] {
    try {
      const ScopedStage stage("decoding the images of frame 4");
      throw std::bad_alloc();
    } catch (...) {
      failure = CaptureFailure();
    }
  });
  worker.join();
  ASSERT_TRUE(failure);
  EXPECT_EQ(failure.stage, "decoding the images of frame 4");
  try {
    const ScopedStage stage("frontend");
    RethrowFailure(failure);
  } catch (const std::bad_alloc&) {
    EXPECT_EQ(FailedStage(), "decoding the images of frame 4");
  }
}

TEST(Stage, OutOfMemoryMessage) {
  EXPECT_EQ(OutOfMemoryMessage("run", "run --out a: frontend: frame 3", "std::bad_alloc"),
            "mcvo run: error: out of memory in run --out a: frontend: frame 3 (std::bad_alloc)");
  EXPECT_EQ(OutOfMemoryMessage("synth", "", "std::bad_alloc"),
            "mcvo synth: error: out of memory (std::bad_alloc)");
}

}  // namespace
}  // namespace mcvo
