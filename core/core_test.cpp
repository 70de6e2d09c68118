#include "core/core.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sys/stat.h>
#include <unistd.h>

namespace radbake {
namespace {

namespace fs = std::filesystem;

TEST(Transforms, InvertAffineUndoesAMirroringShearingNode) {
  // Column-major: x scaled by −2 (a mirror), y sheared into x, then translated.
  const Matrix4 m{-2, 0, 0, 0, 0.5, 1, 0, 0, 0, 0, 3, 0, 4, -5, 6, 1};
  EXPECT_DOUBLE_EQ(determinant3(m), -6);
  const Vec3 p{0.25, -1.5, 2};
  const Vec3 back = transformPoint(invertAffine(m), transformPoint(m, p));
  EXPECT_NEAR(back.x, p.x, 1e-14);
  EXPECT_NEAR(back.y, p.y, 1e-14);
  EXPECT_NEAR(back.z, p.z, 1e-14);
}

TEST(Files, LowerExtensionKeepsTheDotAndOnlyTheLastExtension) {
  EXPECT_EQ(lowerExtension("Dir.D/Scene.Baked.GLB"), ".glb");
  EXPECT_EQ(lowerExtension("out.gltf"), ".gltf");
  EXPECT_EQ(lowerExtension("dir.d/noext"), "");
}

std::string contents(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(Files, AtomicWritesAreAllOrNothing) {
  const fs::path dir = fs::temp_directory_path() / ("radbake-core-test-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string a = (dir / "a.txt").string(), b = (dir / "b.bin").string();
  writeFilesAtomically({{a, "first"}, {b, std::string("\0\1", 2)}});
  EXPECT_EQ(contents(a), "first");
  EXPECT_EQ(contents(b), std::string("\0\1", 2));

  // The second file cannot be written: the first is not replaced and no temporary stays behind.
  fs::remove(a);
  try {
    writeFilesAtomically({{a, "second"}, {(dir / "missing" / "c.txt").string(), "x"}});
    ADD_FAILURE() << "expected Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kCannotWrite);
    EXPECT_NE(std::string(e.what()).find("c.txt: cannot write"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(a));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 1);  // b.bin alone
  fs::remove_all(dir);
}

TEST(Messages, OneLineKeepsTheFirstLineBoundedAndPrintable) {
  EXPECT_EQ(oneLine("a: b\nsecond line"), "a: b");
  EXPECT_EQ(oneLine("tab\there\x1b[31m"), "tabhere[31m");
  const std::string cut = oneLine("x: " + std::string(3'000'000, 'A'));
  EXPECT_EQ(cut.size(), kMaxMessageLength);
  EXPECT_TRUE(cut.ends_with("..."));
  // A cut never leaves half of a UTF-8 character.
  const std::string utf8 = oneLine(std::string(kMaxMessageLength - 4, 'a') + "\u00e9\u00e9\u00e9");
  EXPECT_EQ(utf8, std::string(kMaxMessageLength - 4, 'a') + "...");
  EXPECT_EQ(std::string(Error(ExitCode::kInvalidInput, "f: " + std::string(5000, 'b')).what()).size(), kMaxMessageLength);
}

TEST(Files, ReadRegularFileRefusesFifosDevicesDirectoriesAndOversizedFiles) {
  const fs::path dir = fs::temp_directory_path() / ("radbake_core_read_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string fifo = (dir / "pipe").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto code = [](const std::string& path, uint64_t limit, std::string& message) {
    try {
      readRegularFile(path, "X", limit);
    } catch (const Error& e) {
      message = e.what();
      return int(e.code());
    }
    return 0;
  };
  std::string message;
  EXPECT_EQ(code(fifo, 1 << 20, message), 2);  // returns at once instead of waiting for a writer
  EXPECT_EQ(message, "X: not a regular file (a FIFO); radbake reads only regular files");
  EXPECT_EQ(code("/dev/zero", 1 << 20, message), 2);
  EXPECT_NE(message.find("character device"), std::string::npos) << message;
  EXPECT_EQ(code(dir.string(), 1 << 20, message), 2);
  EXPECT_NE(message.find("directory"), std::string::npos) << message;
  EXPECT_EQ(code((dir / "missing").string(), 1 << 20, message), 2);
  EXPECT_EQ(message, "X: cannot open: no such file");
  EXPECT_EQ(regularFileProblem(fifo), "not a regular file (a FIFO)");
  EXPECT_EQ(regularFileProblem((dir / "missing").string()), "cannot open: no such file");
  const std::string file = (dir / "f.bin").string();
  std::ofstream(file) << "12345";
  EXPECT_EQ(regularFileProblem(file), "");
  EXPECT_EQ(readRegularFile(file, "X", 5).size(), 5u);
  EXPECT_EQ(code(file, 4, message), 3);
  EXPECT_NE(message.find("--max-memory"), std::string::npos) << message;
  fs::remove_all(dir);
}

TEST(Memory, ParseByteSizeTakesUnitsAndRefusesNonsense) {
  EXPECT_EQ(parseByteSize("2G"), uint64_t(2) << 30);
  EXPECT_EQ(parseByteSize("512M"), uint64_t(512) << 20);
  EXPECT_EQ(parseByteSize("1.5GiB"), uint64_t(3) << 29);
  EXPECT_EQ(parseByteSize("4096"), 4096u);
  for (const char* bad : {"-5", "banana", "nan", "inf", "1e300", "0", "2X", "", "G"})
    EXPECT_FALSE(parseByteSize(bad).has_value()) << bad;
  EXPECT_EQ(formatBytes(1.5 * (1 << 30)), "1.5 GiB");
  EXPECT_EQ(formatBytes(512), "512 bytes");
  EXPECT_GT(physicalMemoryBytes(), uint64_t(1) << 26);
}

TEST(Color, SrgbDecodeInvertsEncodeInBothPrecisions) {
  for (double x : {0.0, 0.001, 0.05, 0.18, 0.5, 1.0}) {
    EXPECT_NEAR(srgbDecode(srgbEncode(x)), x, 1e-12) << x;
    EXPECT_NEAR(srgbDecode<float>(float(srgbEncode(x))), x, 1e-6) << x;
  }
}

}  // namespace
}  // namespace radbake
