// REFS.csv parsing (each bad row named with its line) and burst folder listing of the survey
// commands.
#include "client/survey_commands.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "client/command_context.h"

namespace texfree::client {
namespace {

TEST(SurveyCommandsTest, ReferencesCsvParses) {
  const auto refs = ParseReferencesCsv(
      "id,x,y,z\n1,42.55,70.2,11.3\n# a comment\n2, 42.4 ,73.1,15.6\r\n\n7,50.1,78.4,19.8\n",
      "refs.csv");
  ASSERT_EQ(refs.size(), 3u);
  EXPECT_DOUBLE_EQ(refs.at(2).x, 42.4);
  EXPECT_DOUBLE_EQ(refs.at(7).z, 19.8);
  // Columns in another order, extra columns ignored.
  const auto other = ParseReferencesCsv("name,z,y,x,id\na,3,2,1,5\n", "r.csv");
  EXPECT_DOUBLE_EQ(other.at(5).x, 1);
  EXPECT_DOUBLE_EQ(other.at(5).z, 3);
}

void ExpectBadRow(const std::string& text, const std::string& needle) {
  try {
    ParseReferencesCsv(text, "refs.csv");
    FAIL() << "accepted: " << text;
  } catch (const CliError& e) {
    EXPECT_EQ(e.exit_code(), kExitUsage);
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(SurveyCommandsTest, ReferencesCsvBadRowsNamed) {
  ExpectBadRow("1,2,3,4\n", "header id,x,y,z");
  ExpectBadRow("id,x,y,z\n1,2,3\n", "refs.csv:2");
  ExpectBadRow("id,x,y,z\n1,2,3,4\n2,a,3,4\n", "refs.csv:3: x, y, z must be numbers");
  ExpectBadRow("id,x,y,z\n64,2,3,4\n", "not a light id");
  ExpectBadRow("id,x,y,z\n1.5,2,3,4\n", "not a light id");
  ExpectBadRow("id,x,y,z\n1,2,3,4\n1,2,3,4\n", "listed twice");
  ExpectBadRow("id,x,y,z\n", "no reference lights");
}

TEST(SurveyCommandsTest, BurstFolderSortedByName) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("texfree-burst-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* name : {"DSC_0002.JPG", "DSC_0001.jpg", "notes.txt", "DSC_0003.tif"}) {
    std::ofstream(dir / name) << "x";
  }
  const auto files = BurstFrameFiles(dir);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0].filename(), "DSC_0001.jpg");
  EXPECT_EQ(files[2].filename(), "DSC_0003.tif");
  fs::remove_all(dir);
  EXPECT_THROW(BurstFrameFiles(dir), CliError);
}

}  // namespace
}  // namespace texfree::client
