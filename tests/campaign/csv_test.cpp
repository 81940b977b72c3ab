// The campaign library's RFC 4180 reader (campaign/csv.h) on the cases campaign.csv can hold
// (a `detail` with commas, quotes and line breaks) and on malformed files.
#include "lander/campaign/csv.h"

#include <gtest/gtest.h>

#include "lander/core/params_io.h"

namespace lander::campaign {
namespace {

// The message of the ConfigError parse_csv throws for `text` ("" when it does not throw).
std::string parse_error(const std::string& text) {
  try {
    parse_csv(text, "f.csv");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Csv, QuotedFieldsKeepCommasQuotesAndLineBreaks) {
  const std::string text =
      "id,detail,x\n"
      "a,plain,1\n"
      "b,\"one, two\",2\n"
      "c,\"say \"\"hi\"\"\",3\n"
      "d,\"line 1\nline 2\r\nline 3\",4\n"
      "e,,\n"
      "f,\"\",6\n";
  const CsvTable t = parse_csv(text, "f.csv");
  ASSERT_EQ(t.header, (std::vector<std::string>{"id", "detail", "x"}));
  ASSERT_EQ(t.records.size(), 6u);
  EXPECT_EQ(t.records[0].cells[1], "plain");
  EXPECT_EQ(t.records[1].cells[1], "one, two");
  EXPECT_EQ(t.records[2].cells[1], "say \"hi\"");
  EXPECT_EQ(t.records[3].cells[1], "line 1\nline 2\r\nline 3");
  EXPECT_EQ(t.records[3].cells[2], "4");
  EXPECT_EQ(t.records[4].cells, (std::vector<std::string>{"e", "", ""}));
  EXPECT_EQ(t.records[5].cells[1], "");
  // Lines count the breaks inside quotes: record e starts on line 8.
  EXPECT_EQ(t.records[0].line, 2);
  EXPECT_EQ(t.records[3].line, 5);
  EXPECT_EQ(t.records[4].line, 8);
  EXPECT_EQ(t.column("x"), 2);
  EXPECT_EQ(t.column("nope"), -1);
}

TEST(Csv, CrlfBomBlankLinesAndNoFinalBreak) {
  const CsvTable t = parse_csv("\xEF\xBB\xBFid,v\r\na,1\r\n\r\nb,\"2\"", "f.csv");
  ASSERT_EQ(t.header, (std::vector<std::string>{"id", "v"}));
  ASSERT_EQ(t.records.size(), 2u);
  EXPECT_EQ(t.records[0].cells, (std::vector<std::string>{"a", "1"}));
  EXPECT_EQ(t.records[1].cells, (std::vector<std::string>{"b", "2"}));
  EXPECT_EQ(t.records[1].line, 4);
}

TEST(Csv, MalformedInputNamesFileAndLine) {
  EXPECT_NE(parse_error("id,v\na,\"open\nb,2\n").find("f.csv:2: unterminated quoted field"),
            std::string::npos);
  EXPECT_NE(parse_error("id,v\na,b\"c\n").find("f.csv:2: quote inside an unquoted field"),
            std::string::npos);
  EXPECT_NE(parse_error("id,v\na,\"b\"c\n").find("f.csv:2: text after the closing quote"),
            std::string::npos);
  EXPECT_NE(parse_error("id,v\na,\"x\ny\"\nb,1,2\n").find("f.csv:4: 3 fields, the header has 2"),
            std::string::npos);
  EXPECT_NE(parse_error("id,id\n").find("f.csv:1: column 'id' appears twice"), std::string::npos);
  EXPECT_NE(parse_error("id,,v\n").find("f.csv:1: empty column name"), std::string::npos);
  EXPECT_NE(parse_error("\n\n").find("f.csv: empty"), std::string::npos);
  EXPECT_EQ(parse_error("id\n"), "");  // a header alone is a table without records
}

TEST(Csv, MissingFileIsAConfigError) {
  EXPECT_THROW(read_csv_file("/nonexistent/campaign.csv"), ConfigError);
}

}  // namespace
}  // namespace lander::campaign
