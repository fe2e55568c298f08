// Issue #52: a batch's checkpoint keeps items across jobs: a new one is
// created, an existing one refused without resume and read with it, its
// identity compared key by key (the first that differs named), a damaged
// item named by its file, and the folder removed at the end.
#include "records/batch_checkpoint.h"

#include <filesystem>
#include <fstream>

#include "gtest/gtest.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

class BatchCheckpointTest : public TempDirTest {};

TEST_F(BatchCheckpointTest, ItemsSurviveTheJobAndAnotherRunIsRefused) {
  const std::string folder = Path("out.json.checkpoint");
  const BatchCheckpoint::Identity identity = {{"seed", "2"}, {"cases", "3"}};
  {
    BatchCheckpoint first;
    ASSERT_TRUE(first.Open(folder, identity, 3, false).ok());
    ASSERT_TRUE(first.Record(2, "{\"x\": \"two\"}", 1.5).ok());
    ASSERT_TRUE(first.Record(0, "zero", 0.25).ok());

    BatchCheckpoint again;
    Status status = again.Open(folder, identity, 3, false);
    EXPECT_NE(status.message().find("--resume goes on from it"),
              std::string::npos)
        << status.message();
    status = again.Open(folder, {{"seed", "3"}, {"cases", "3"}}, 3, true);
    EXPECT_NE(status.message().find("(seed was 2, is 3)"), std::string::npos)
        << status.message();
    // Two jobs resuming one checkpoint at once: the second is refused.
    status = again.Open(folder, identity, 3, true);
    EXPECT_NE(status.message().find("in use by another run"), std::string::npos)
        << status.message();
  }  // the job ends: the folder is free

  BatchCheckpoint resumed;
  ASSERT_TRUE(resumed.Open(folder, identity, 3, true).ok());
  ASSERT_EQ(resumed.items().size(), 2u);
  EXPECT_EQ(resumed.items().at(2).result, "{\"x\": \"two\"}");
  EXPECT_EQ(resumed.items().at(2).seconds, 1.5);
  EXPECT_EQ(resumed.items().at(0).result, "zero");

  std::ofstream(folder + "/item-000001.json") << "{\"item\": 2, \"result\"";
  Status status = resumed.Open(folder, identity, 3, true);
  EXPECT_NE(status.message().find("item-000001.json: not a checkpoint item"),
            std::string::npos)
      << status.message();
  std::ofstream(folder + "/item-000001.json")
      << R"({"item": 2, "seconds": 1, "result": "x"})";
  status = resumed.Open(folder, identity, 3, true);
  EXPECT_NE(status.message().find("item-000001.json: holds another item"),
            std::string::npos)
      << status.message();

  ASSERT_TRUE(resumed.Remove().ok());
  EXPECT_FALSE(std::filesystem::exists(folder));
  // Resuming where there is none starts it (a requeued job's first run).
  ASSERT_TRUE(resumed.Open(folder, identity, 3, true).ok());
  EXPECT_TRUE(resumed.items().empty());
  EXPECT_TRUE(std::filesystem::is_directory(folder));
  // A file where the folder should be is named, never taken for one.
  ASSERT_TRUE(resumed.Remove().ok());
  std::ofstream(folder) << "x";
  status = resumed.Open(folder, identity, 3, true);
  EXPECT_NE(status.message().find("exists and is not a checkpoint folder"),
            std::string::npos)
      << status.message();
}

TEST_F(BatchCheckpointTest, DigestsSeeEveryByteAndName) {
  std::filesystem::create_directories(Path("cfg"));
  std::ofstream(Path("cfg/a.yaml")) << "k: 1\n";
  const std::string before = InputDigest(Path("cfg"));
  EXPECT_EQ(before.size(), 16u);
  std::ofstream(Path("cfg/a.yaml")) << "k: 2\n";
  EXPECT_NE(InputDigest(Path("cfg")), before);
  std::ofstream(Path("cfg/a.yaml")) << "k: 1\n";
  EXPECT_EQ(InputDigest(Path("cfg")), before);
  std::filesystem::rename(Path("cfg/a.yaml"), Path("cfg/b.yaml"));
  EXPECT_NE(InputDigest(Path("cfg")), before);
  EXPECT_EQ(InputDigest(Path("missing")), "");
}

}  // namespace
}  // namespace kcrig
