// PROTOCOL.md's worked examples are the encoder's output: each `ex-...` row's hex must equal the
// frame encoded here, and the document must have no row this table does not know.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "doc_examples.hpp"
#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

std::string read_doc() {
    std::ifstream in(GLINT_PROTOCOL_DOC);
    EXPECT_TRUE(in) << "cannot open " << GLINT_PROTOCOL_DOC;
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The row of the examples table tagged `name`, or "" when absent.
std::string find_row(const std::string& doc, const std::string& name) {
    const std::string tag = "| `" + name + "` |";
    const std::size_t at = doc.find(tag);
    if (at == std::string::npos) return "";
    return doc.substr(at, doc.find('\n', at) - at);
}

// The text between the last pair of backticks of a row: the frame's hex.
std::string last_code_span(const std::string& row) {
    const std::size_t close = row.rfind('`');
    if (close == std::string::npos || close == 0) return "";
    const std::size_t open = row.rfind('`', close - 1);
    if (open == std::string::npos) return "";
    return row.substr(open + 1, close - open - 1);
}

TEST(DocExamples, EveryExampleFrameInProtocolMdMatchesTheEncoder) {
    const std::string doc = read_doc();
    ASSERT_FALSE(doc.empty());
    for (const test::DocExample& ex : test::doc_examples()) {
        const std::string expected = test::hex(test::encode(ex.message, ex.seq));
        const std::string row = find_row(doc, ex.name);
        // On failure, print the row as it should read so the document is easy to fix.
        EXPECT_EQ(last_code_span(row), expected)
            << "PROTOCOL.md row `" << ex.name << "` should end with:\n| `" << ex.name << "` | ... | `" << expected << "` |";
    }
}

TEST(DocExamples, DocumentHasNoStaleExampleRows) {
    const std::string doc = read_doc();
    std::size_t rows = 0;
    for (std::size_t at = doc.find("| `ex-"); at != std::string::npos; at = doc.find("| `ex-", at + 1)) ++rows;
    EXPECT_EQ(rows, test::doc_examples().size());
}

TEST(DocExamples, ExamplesDecodeBackToTheirMessages) {
    for (const test::DocExample& ex : test::doc_examples()) {
        FrameDecoder d;
        const auto events = test::decode_stream(d, test::encode(ex.message, ex.seq));
        ASSERT_EQ(events.size(), 1u) << ex.name;
        EXPECT_EQ(events[0].status, FrameStatus::Ok) << ex.name;
        EXPECT_TRUE(events[0].message == ex.message) << ex.name;
    }
}

}  // namespace
}  // namespace glint::protocol
