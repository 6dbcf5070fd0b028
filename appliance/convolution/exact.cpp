// The exact method: every non-zero term of the conventions' sums.
#include "appliance/convolution/methods.hpp"

#include "appliance/core/parallel.hpp"

namespace glint::convolution {

HdrImage exact_convolve(const PreparedLevel& input, double shininess, Size out, int threads,
                        const RowProgress& progress) {
    const LobeSummer summer(input, out.width, out.height, shininess);
    LobeSums sums = summer.make_sums();
    summer.lay_out();  // with all threads, not inside the first row
    parallel_for(out.height, threads, [&](int row) {
        summer.sum_row(row, 0.0, sums);
        if (progress) progress(1);
    });
    return finish_sums(sums);
}

}  // namespace glint::convolution
