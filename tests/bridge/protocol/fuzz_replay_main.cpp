// Replays fuzz inputs without libFuzzer: calls a fuzz target's LLVMFuzzerTestOneInput once for
// every file named on the command line. Built with the default compiler (GCC has no libFuzzer),
// so the committed seed corpora (tests/bridge/*/corpus) run in every ctest -L bridge, through
// the same entry code and the same checks (a failed check aborts: the test fails) as
// scripts/run-fuzz.sh uses. Shared by tests/bridge/protocol and tests/bridge/recording.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s INPUT...\n", argv[0]);
        return 2;
    }
    for (int i = 1; i < argc; ++i) {
        std::ifstream in(argv[i], std::ios::binary);
        if (!in) {
            std::fprintf(stderr, "cannot read %s\n", argv[i]);
            return 1;  // a missing seed must not pass as "nothing to check"
        }
        const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (bytes.empty()) {
            std::fprintf(stderr, "%s is empty: not a seed\n", argv[i]);
            return 1;
        }
        const int rc = LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
        std::printf("%s: %zu bytes, fuzz target returned %d\n", argv[i], bytes.size(), rc);
        if (rc != 0) return 1;
    }
    return 0;
}
