// Test helper for tests/cli/test_track_cli.sh: renders N frames of the default board at known
// poses (appliance/tracking/board_view.hpp) into DIR/frames/NNN.png, writes the true poses to
// DIR/truth.csv (file,qw,qx,qy,qz,tx,ty,tz: camera_from_board) and prints the intrinsics as
// fx,fy,cx,cy,k1,k2,p1,p2,k3. Frames listed after --blank show only the table (a dropout).
//
// Usage: render_board_views DIR N [--blank I ...]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>

#include "appliance/tracking/board_view.hpp"

int main(int argc, char** argv) {
    using namespace glint::tracking;
    if (argc < 3) {
        std::fprintf(stderr, "usage: render_board_views DIR N [--blank I ...]\n");
        return 2;
    }
    const std::filesystem::path dir = argv[1];
    const int n = std::atoi(argv[2]);
    std::set<int> blank;
    for (int i = 4; i < argc; ++i) blank.insert(std::atoi(argv[i]));
    std::filesystem::create_directories(dir / "frames");
    const Board board;
    Camera cam = Camera::from_fov(960, 540, 70);
    cam.k1 = -0.08, cam.k2 = 0.02;
    const BoardRenderer renderer(board, cam, 2);
    std::ofstream truth(dir / "truth.csv");
    truth.precision(17);
    truth << "file,qw,qx,qy,qz,tx,ty,tz\n";
    for (int i = 0; i < n; ++i) {
        // A slow turn: 1 degree of roll and 0.5 of tilt per frame.
        const Pose p = view_pose(0.7, 25 + 0.5 * i, 40, 10 + i);
        char name[32];
        std::snprintf(name, sizeof name, "%03d.png", i);
        const cv::Mat image = blank.count(i) ? cv::Mat(cam.height, cam.width, CV_8UC1, cv::Scalar(77))
                                             : renderer.render(p, {}, std::uint64_t(i));
        cv::imwrite((dir / "frames" / name).string(), image);
        truth << name << "," << p.rotation.w << "," << p.rotation.x << "," << p.rotation.y << "," << p.rotation.z << ","
              << p.translation.x << "," << p.translation.y << "," << p.translation.z << "\n";
    }
    std::printf("%.10g,%.10g,%.10g,%.10g,%g,%g,0,0,0\n", cam.fx, cam.fy, cam.cx, cam.cy, cam.k1, cam.k2);
    return 0;
}
