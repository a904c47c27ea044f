// io/yaml.hpp: the one opener of YAML documents (scenes, studies, courses, answers) and the one
// built-in-or-file loader.
#include "cariesim/io/yaml.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cariesim/common/error.hpp"
#include "support/fifo.hpp"

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;

// The message of the Error `f` throws ("" when it throws none).
template <typename F>
std::string message(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ParseDocument, ReadsOneDocumentAndAnEmptyOneIsNull) {
  const YAML::Node root = parse_document("name: a\nlist: [1, 2]\n", "doc.yaml");
  ASSERT_TRUE(root.IsMap());
  EXPECT_EQ(root["list"].size(), 2u);
  EXPECT_TRUE(parse_document("", "doc.yaml").IsNull());
  EXPECT_TRUE(parse_document("# only a comment\n", "doc.yaml").IsNull());
  // A document end marker is no second document.
  EXPECT_TRUE(parse_document("a: 1\n...\n", "doc.yaml").IsMap());
}

// A second document was silently ignored by YAML::Load: what a reviewer reads after `---` is not
// what runs. It is refused where it starts.
TEST(ParseDocument, ASecondDocumentIsRefused) {
  const std::string m = message([] { (void)parse_document("a: 1\n---\nb: 2\n", "doc.yaml"); });
  EXPECT_NE(m.find("doc.yaml:3:1: a second YAML document"), std::string::npos) << m;
}

TEST(ParseDocument, SyntaxErrorsAreLocated) {
  const std::string m = message([] { (void)parse_document("a: [1, 2\nb: 3\n", "doc.yaml"); });
  EXPECT_EQ(m.rfind("doc.yaml:", 0), 0u) << m;
  EXPECT_NE(m.find("YAML syntax error"), std::string::npos) << m;
  // yaml-cpp's own nesting bound (DeepRecursion) is a located syntax error too.
  const std::string deep = std::string(5000, '[') + std::string(5000, ']');
  EXPECT_NE(message([&] { (void)parse_document(deep, "deep.yaml"); }).find("YAML syntax error"),
            std::string::npos);
}

TEST(ParseDocument, TextOverItsBoundIsRefused) {
  const std::string m = message([] { (void)parse_document("a: 12345\n", "doc.yaml", 5); });
  EXPECT_NE(m.find("doc.yaml: too large (9 bytes, at most 5)"), std::string::npos) << m;
}

// A "billion laughs" document: ten aliases per level, nine levels, 10^9 nodes from 300 bytes. It is
// refused before anything walks it.
TEST(ParseDocument, ABillionLaughsIsRefused) {
  std::string yaml = "l0: &l0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i <= 9; ++i) {
    const std::string prev = "*l" + std::to_string(i - 1);
    yaml += "l" + std::to_string(i) + ": &l" + std::to_string(i) + " [";
    for (int k = 0; k < 10; ++k) yaml += (k ? ", " : "") + prev;
    yaml += "]\n";
  }
  const std::string m = message([&] { (void)parse_document(yaml, "bomb.yaml"); });
  EXPECT_NE(m.find("bomb.yaml:"), std::string::npos) << m;
  EXPECT_NE(m.find("more than 4194304 nodes through its aliases"), std::string::npos) << m;
  // A few aliases are fine.
  EXPECT_TRUE(parse_document("a: &a [1, 2]\nb: [*a, *a]\n", "ok.yaml").IsMap());
}

TEST(ParseDocument, AnAliasInsideItsOwnAnchorIsRefused) {
  const std::string m = message([] { (void)parse_document("objects: &x [*x]\n", "loop.yaml"); });
  EXPECT_NE(m.find("loop.yaml:1:10: an alias names a node that contains it"), std::string::npos) << m;
  const std::string deeper = message([] { (void)parse_document("a: &x {b: [{c: *x}]}\n", "loop.yaml"); });
  EXPECT_NE(deeper.find("an alias names a node that contains it"), std::string::npos) << deeper;
}

class BuiltinOrFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-io-yaml-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(BuiltinOrFile, ABuiltInWinsThenAFileIsRead) {
  const NamedText b = builtin_or_file("tuning", "study", "kind: tuning\n", {"tuning"});
  EXPECT_TRUE(b.builtin);
  EXPECT_EQ(b.origin, "builtin:tuning");
  EXPECT_EQ(b.text, "kind: tuning\n");
  const fs::path file = dir_ / "s.yaml";
  std::ofstream(file) << "kind: diagnosis\n";
  const NamedText f = builtin_or_file(file.string(), "study", "", {"tuning"});
  EXPECT_FALSE(f.builtin);
  EXPECT_EQ(f.origin, file);
  EXPECT_EQ(f.text, "kind: diagnosis\n");
}

TEST_F(BuiltinOrFile, NothingThereListsTheBuiltInsAndAFifoIsNamed) {
  const std::string missing = (dir_ / "none.yaml").string();
  EXPECT_NE(message([&] {
              (void)builtin_or_file(missing, "scene", "", {"a", "b"});
            }).find(missing + ": no such scene file, and not a built-in scene (a, b)"),
            std::string::npos);
  const fs::path fifo = dir_ / "pipe.yaml";
  ASSERT_TRUE(test::make_fifo(fifo));
  const test::FifoOutcome outcome =
      test::read_fifo(fifo, [fifo] { (void)builtin_or_file(fifo.string(), "scene", "", {"a"}); });
  EXPECT_FALSE(outcome.blocked);
  EXPECT_NE(outcome.error.find("scene: not a regular file (a FIFO (named pipe))"), std::string::npos)
      << outcome.error;
}

}  // namespace
}  // namespace cariesim::io
