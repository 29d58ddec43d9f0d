// ReadFileBytes (core/common/file_bytes.h), the reader of files named by flags: the bytes as they
// are, and an error naming the flag, the path and the reason.
#include "core/common/file_bytes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

namespace hgraph {
namespace {

namespace fs = std::filesystem;

class FileBytesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hgraph_file_bytes_test_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& bytes) const {
    const fs::path file = dir_ / name;
    std::ofstream(file, std::ios::binary) << bytes;
    return file.string();
  }
  // The message of the Error ReadFileBytes throws, after checking its code and field.
  static std::string ErrorText(const std::string& path, const std::string& field) {
    try {
      ReadFileBytes(path, field);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kNotFound);
      EXPECT_EQ(e.field(), field);
      return e.what();
    }
    ADD_FAILURE() << "no error reading " << path;
    return "";
  }

  fs::path dir_;
};

TEST_F(FileBytesTest, ReadsEveryByte) {
  std::string bytes(150000, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i % 251);
  EXPECT_EQ(ReadFileBytes(Write("key.pem", bytes), "--tls-key"), bytes);
  EXPECT_EQ(ReadFileBytes(Write("empty", ""), "--tls-key"), "");
}

TEST_F(FileBytesTest, ErrorsNameTheFlagThePathAndTheReason) {
  const std::string none = (dir_ / "none.pem").string();
  EXPECT_EQ(ErrorText(none, "--tls-ca"),
            "--tls-ca: cannot read " + none + ": No such file or directory");
  const std::string through = Write("file", "x") + "/x";
  EXPECT_EQ(ErrorText(through, "--tls-ca"),
            "--tls-ca: cannot read " + through + ": Not a directory");
  // A directory opens; its read fails.
  EXPECT_EQ(ErrorText(dir_.string(), "--tls-cert"),
            "--tls-cert: cannot read " + dir_.string() + ": Is a directory");
}

TEST_F(FileBytesTest, TryReadSaysWhetherTheOpenOrTheReadFailed) {
  std::string bytes = "kept";
  const std::optional<FileReadFailure> missing = TryReadFileBytes((dir_ / "none").string(), &bytes);
  ASSERT_TRUE(missing.has_value());
  EXPECT_TRUE(missing->at_open);
  EXPECT_EQ(missing->error, ENOENT);
  const std::optional<FileReadFailure> directory = TryReadFileBytes(dir_.string(), &bytes);
  ASSERT_TRUE(directory.has_value());
  EXPECT_FALSE(directory->at_open);
  EXPECT_EQ(directory->error, EISDIR);
  EXPECT_EQ(bytes, "kept");
  EXPECT_FALSE(TryReadFileBytes(Write("f", "abc"), &bytes).has_value());
  EXPECT_EQ(bytes, "abc");
}

}  // namespace
}  // namespace hgraph
