#include "appliance/render/shadow.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <glm/gtc/type_ptr.hpp>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/render/shadow_bake.hpp"

namespace glint::render {
namespace {


// Inside when two of three axis rays cross the surface an odd number of times (a mesh with small
// holes or a vertex hit exactly still gets a majority).
bool inside(const Mesh& mesh, const glm::dvec3& p) {
    // Slightly skewed axes: a ray along an exact axis through a grid-aligned mesh hits edges.
    const glm::dvec3 axes[3] = {glm::normalize(glm::dvec3(1, 1e-3, 2e-3)), glm::normalize(glm::dvec3(2e-3, 1, 1e-3)),
                                glm::normalize(glm::dvec3(1e-3, 2e-3, 1))};
    int odd = 0;
    for (const glm::dvec3& d : axes) {
        int hits = 0;
        for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
            if (ray_crosses_triangle(p, d, mesh.positions[mesh.indices[t]], mesh.positions[mesh.indices[t + 1]],
                        mesh.positions[mesh.indices[t + 2]]))
                ++hits;
        odd += hits % 2;
    }
    return odd >= 2;
}

// Solid-angle weighted block means down to w x h when the map divides; otherwise bilinear
// resampling (the ambient part has no sharp lights left, so little is lost).
HdrImage block_means(const HdrImage& map, int w, int h) {
    if (map.width() % w != 0 || map.height() % h != 0) return resample_bilinear(map, w, h);
    const int fx = map.width() / w, fy = map.height() / h;
    const std::vector<double> domega = row_solid_angles(map.width(), map.height());
    HdrImage out(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            double s[3] = {0, 0, 0}, wsum = 0;
            for (int y = j * fy; y < (j + 1) * fy; ++y) {
                const double dw = domega[std::size_t(y)];
                for (int x = i * fx; x < (i + 1) * fx; ++x) {
                    for (int c = 0; c < 3; ++c) s[c] += dw * map.row(y)[3 * x + c];
                    wsum += dw;
                }
            }
            out.set(i, j, {float(s[0] / wsum), float(s[1] / wsum), float(s[2] / wsum)});
        }
    return out;
}

}  // namespace

HdrImage ambient_cap_density(const HdrImage& map, double radius) {
    if (radius <= 0) {
        HdrImage out = block_means(map, kCapW, kCapH);
        for (int j = 0; j < kCapH; ++j) {
            const float y = float(std::max(0.0, std::cos(row_theta(j, kCapH))));
            for (int i = 0; i < 3 * kCapW; ++i) out.row(j)[i] *= y;
        }
        return out;
    }
    // A texel k is in the cap of o when o . w_k >= cos(radius). In an equirect map that is, for
    // each input row, one run of columns around o's longitude (|dphi| <= alpha with
    // cos(alpha) = (cos r - cos t_o cos t_k) / (sin t_o sin t_k)): the sum over a row is a
    // difference of that row's prefix sums, so a cap costs one step per input row, not one per
    // input texel (the brute-force sum over every texel took 0.45 s at start-up for 6 levels).
    const int w = map.width(), h = map.height();
    const std::vector<double> domega = row_solid_angles(w, h);
    const double cos_r = std::cos(radius);
    std::vector<double> row_cos(static_cast<std::size_t>(h)), row_sin(static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y) {
        row_cos[std::size_t(y)] = std::cos(row_theta(y, h));
        row_sin[std::size_t(y)] = std::sin(row_theta(y, h));
    }
    // Per input row: the prefix sums of L max(0, w.y) over two laps of the columns, so that a run
    // across the seam is one difference too.
    std::vector<glm::dvec3> prefix(std::size_t(h) * std::size_t(2 * w + 1));
    for (int y = 0; y < h; ++y) {
        const double facing = std::max(0.0, row_cos[std::size_t(y)]);
        glm::dvec3* pre = &prefix[std::size_t(y) * std::size_t(2 * w + 1)];
        pre[0] = glm::dvec3(0.0);
        for (int x = 0; x < 2 * w; ++x) {
            const float* p = map.row(y) + 3 * (x % w);
            pre[x + 1] = pre[x] + facing * glm::dvec3(p[0], p[1], p[2]);
        }
    }
    std::vector<glm::dvec3> dirs(std::size_t(w) * std::size_t(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) dirs[std::size_t(y) * std::size_t(w) + std::size_t(x)] = texel_direction(x, y, w, h);
    const auto dir = [&](int x, int y) { return dirs[std::size_t(y) * std::size_t(w) + std::size_t(((x % w) + w) % w)]; };
    const auto in_cap = [&](const glm::dvec3& o, int x, int y) { return glm::dot(o, dir(x, y)) >= cos_r; };
    HdrImage out(kCapW, kCapH);
    for (int j = 0; j < kCapH; ++j) {
        const double cos_o = std::cos(row_theta(j, kCapH)), sin_o = std::sin(row_theta(j, kCapH));
        for (int i = 0; i < kCapW; ++i) {
            const glm::dvec3 o = texel_direction(i, j, kCapW, kCapH);
            // o's longitude in input columns (column x's centre is at x + 0.5).
            const double centre = (column_phi(i, kCapW) + kPi) / kTwoPi * w - 0.5;
            glm::dvec3 sum(0.0);
            double wsum = 0, nearest = -2;
            glm::dvec3 nearest_value(0.0);
            for (int y = 0; y < h; ++y) {
                // The row's texel nearest o (for a cap smaller than a texel).
                for (int x = int(std::floor(centre)); x <= int(std::floor(centre)) + 1; ++x) {
                    const double c = glm::dot(o, dir(x, y));
                    if (c > nearest) {
                        nearest = c;
                        const float* p = map.row(y) + 3 * (((x % w) + w) % w);
                        nearest_value = glm::dvec3(p[0], p[1], p[2]) * std::max(0.0, row_cos[std::size_t(y)]);
                    }
                }
                const double denom = sin_o * row_sin[std::size_t(y)];
                const double c = denom > 0 ? (cos_r - cos_o * row_cos[std::size_t(y)]) / denom : 2.0;
                int lo, hi;  // the run of columns lo..hi (hi - lo < w)
                if (c <= -1) {
                    lo = 0;
                    hi = w - 1;
                } else {
                    const double half = c >= 1 ? 0 : std::acos(c) / kTwoPi * w;  // in columns
                    lo = int(std::ceil(centre - half));
                    hi = int(std::floor(centre + half));
                    // The same texels as the dot product decides: the run's ends checked with it.
                    while (hi - lo + 1 < w && in_cap(o, lo - 1, y)) --lo;
                    while (hi - lo + 1 < w && in_cap(o, hi + 1, y)) ++hi;
                    while (lo <= hi && !in_cap(o, lo, y)) ++lo;
                    while (hi >= lo && !in_cap(o, hi, y)) --hi;
                    if (lo > hi) continue;
                    hi = std::min(hi, lo + w - 1);
                }
                const int shift = lo >= 0 ? -(lo / w) * w : ((-lo + w - 1) / w) * w;  // lo + shift in [0, w)
                const glm::dvec3* pre = &prefix[std::size_t(y) * std::size_t(2 * w + 1)];
                sum += (pre[hi + shift + 1] - pre[lo + shift]) * domega[std::size_t(y)];
                wsum += double(hi - lo + 1) * domega[std::size_t(y)];
            }
            const glm::dvec3 v = wsum > 0 ? sum / wsum : nearest_value;  // a cap smaller than a texel
            out.set(i, j, {float(v.x), float(v.y), float(v.z)});
        }
    }
    return out;
}

double model_bottom(const Mesh& mesh) {
    double y = std::numeric_limits<double>::infinity();
    for (const glm::vec3& p : mesh.positions) y = std::min(y, double(p.y));
    if (!std::isfinite(y)) throw InputError("table: the mesh " + mesh.source + " has no vertices");
    return y;
}

std::vector<OccluderSphere> occluder_spheres(const Mesh& mesh) {
    if (mesh.positions.empty()) throw InputError("shadow: the mesh " + mesh.source + " has no vertices");
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::vec3& p : mesh.positions) {
        lo = glm::min(lo, glm::dvec3(p));
        hi = glm::max(hi, glm::dvec3(p));
    }
    const glm::dvec3 centre = 0.5 * (lo + hi);
    double mean = 0;
    for (const glm::vec3& p : mesh.positions) mean += glm::length(glm::dvec3(p) - centre);
    mean /= double(mesh.positions.size());
    // The vertices and the triangles' centroids (a cube's corners alone are on a sphere).
    bool sphere = mean > 0;
    auto on_sphere = [&](const glm::dvec3& p) { return std::abs(glm::length(p - centre) - mean) <= 0.01 * mean; };
    for (const glm::vec3& p : mesh.positions) sphere = sphere && on_sphere(glm::dvec3(p));
    for (std::size_t t = 0; sphere && t + 2 < mesh.indices.size(); t += 3)
        sphere = on_sphere((glm::dvec3(mesh.positions[mesh.indices[t]]) + glm::dvec3(mesh.positions[mesh.indices[t + 1]]) +
                            glm::dvec3(mesh.positions[mesh.indices[t + 2]])) / 3.0);
    if (sphere) {
        double r = 0;
        for (const glm::vec3& p : mesh.positions) r = std::max(r, glm::length(glm::dvec3(p) - centre));
        return {{centre, r}};
    }

    const glm::dvec3 extent = hi - lo;
    const double longest = std::max({extent.x, extent.y, extent.z});
    for (int cells = kMaxCellsAlongSide; cells >= 1; --cells) {
        const double side = longest / cells;
        std::vector<OccluderSphere> out;
        const int nx = std::max(1, int(std::ceil(extent.x / side - 1e-9)));
        const int ny = std::max(1, int(std::ceil(extent.y / side - 1e-9)));
        const int nz = std::max(1, int(std::ceil(extent.z / side - 1e-9)));
        // The grid is centred on the box, so a side shorter than a cell still gets one centred cell.
        const glm::dvec3 start = centre - 0.5 * side * glm::dvec3(nx, ny, nz);
        for (int z = 0; z < nz; ++z)
            for (int y = 0; y < ny; ++y)
                for (int x = 0; x < nx; ++x) {
                    const glm::dvec3 p = start + side * (glm::dvec3(x, y, z) + 0.5);
                    if (inside(mesh, p)) out.push_back({p, 0.5 * std::sqrt(3.0) * side});
                }
        if (int(out.size()) <= kMaxOccluders) return out;
    }
    return {};
}

ShadowLighting shadow_lighting(const HdrImage& environment, DominantLightOptions options) {
    options.max_lights = std::min(options.max_lights, kMaxShadowLights);
    options.facing = glm::dvec3(0.0, 1.0, 0.0);  // lights under the table's horizon do not light it
    options.max_angular_radius = kMaxShadowLightRadiusDeg * kPi / 180.0;
    LightDecomposition found = find_dominant_lights(environment, options);
    ShadowLighting out;
    for (DominantLight l : found.lights) {
        // What lights the table: the texels above its horizon, from where they are on average
        // (a light across the horizon is seen from the table as its upper part).
        l.direction = l.facing_direction;
        out.lights.push_back(l);
        out.light_irradiance.push_back(l.facing_irradiance);
    }
    out.ambient_irradiance = irradiance_on(found.ambient, {0.0, 1.0, 0.0});
    const HdrImage input = block_means(found.ambient, 2 * kCapW, 2 * kCapH);
    for (int l = 0; l < kCapLevels; ++l)
        out.ambient_caps.push_back(ambient_cap_density(l == 0 ? found.ambient : input, kCapRadiiDeg[l] * kPi / 180.0));
    return out;
}

TableShadowPass::TableShadowPass(int width, int height, const ShadowLighting& lighting,
                                 std::vector<OccluderSphere> occluders, double table_height)
    : width_(width),
      height_(height),
      table_height_(table_height),
      lighting_(lighting),
      occluders_(std::move(occluders)),
      program_(),
      target_() {
    if (int(lighting_.lights.size()) > kMaxShadowLights) throw RuntimeError("shadow: more lights than the shader holds");
    if (int(occluders_.size()) > kMaxOccluders) throw RuntimeError("shadow: more occluders than the shader holds");
    // The bound: around the spheres' box centre, out to the farthest sphere's far side.
    if (!occluders_.empty()) {
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (const OccluderSphere& s : occluders_) {
            lo = glm::min(lo, s.centre);
            hi = glm::max(hi, s.centre);
        }
        bound_.centre = 0.5 * (lo + hi);
        bound_.radius = 0;
        for (const OccluderSphere& s : occluders_)
            bound_.radius = std::max(bound_.radius, glm::length(s.centre - bound_.centre) + s.radius);
    } else {
        bound_ = {glm::dvec3(0.0, 1e6, 0.0), 0.0};  // nothing: a point far above hides nothing
    }
    if (int(lighting_.ambient_caps.size()) != kCapLevels) throw RuntimeError("shadow: the ambient cap maps are missing");
    // The levels stacked top to bottom in one texture (render_shadow.frag's u_caps).
    HdrImage stack(kCapW, kCapH * kCapLevels);
    for (int l = 0; l < kCapLevels; ++l) {
        const HdrImage& level = lighting_.ambient_caps[std::size_t(l)];
        if (level.width() != kCapW || level.height() != kCapH) throw RuntimeError("shadow: a cap map is not 64x32");
        std::copy(level.data().begin(), level.data().end(),
                  stack.data().begin() + std::ptrdiff_t(std::size_t(l) * level.data().size()));
    }
    caps_ = gl::upload_image(stack);
    empty_vao_ = gl::GlVertexArray::create();
    gl::check_gl("creating the table shadow pass");
}

void TableShadowPass::set_uniforms(const gl::GlProgram& program, int caps_unit, const glm::vec3& eye) const {
    glUniform3f(program.uniform("u_eye"), eye.x, eye.y, eye.z);
    glUniform1f(program.uniform("u_table_height"), float(table_height_));
    const int n = int(lighting_.lights.size());
    std::vector<float> dir, irr, radius;
    for (int i = 0; i < n; ++i) {
        const DominantLight& l = lighting_.lights[std::size_t(i)];
        const glm::dvec3 e = lighting_.light_irradiance[std::size_t(i)];
        dir.insert(dir.end(), {float(l.direction.x), float(l.direction.y), float(l.direction.z)});
        irr.insert(irr.end(), {float(e.x), float(e.y), float(e.z)});
        radius.push_back(float(l.angular_radius()));
    }
    glUniform1i(program.uniform("u_light_count"), n);
    if (n > 0) {
        glUniform3fv(program.uniform("u_light_dir"), n, dir.data());
        glUniform3fv(program.uniform("u_light_irradiance"), n, irr.data());
        glUniform1fv(program.uniform("u_light_radius"), n, radius.data());
    }
    const glm::dvec3 ea = lighting_.ambient_irradiance;
    glUniform3f(program.uniform("u_ambient_irradiance"), float(ea.x), float(ea.y), float(ea.z));
    std::vector<float> spheres;
    for (const OccluderSphere& s : occluders_)
        spheres.insert(spheres.end(), {float(s.centre.x), float(s.centre.y), float(s.centre.z), float(s.radius)});
    glUniform1i(program.uniform("u_sphere_count"), int(occluders_.size()));
    if (!occluders_.empty()) glUniform4fv(program.uniform("u_spheres"), GLsizei(occluders_.size()), spheres.data());
    glUniform4f(program.uniform("u_bound"), float(bound_.centre.x), float(bound_.centre.y), float(bound_.centre.z),
                float(bound_.radius));
    float radii[kCapLevels];
    for (int l = 0; l < kCapLevels; ++l) radii[l] = float(kCapRadiiDeg[l] * kPi / 180.0);
    glUniform1fv(program.uniform("u_cap_radius"), kCapLevels, radii);
    glActiveTexture(GLenum(GL_TEXTURE0 + caps_unit));
    glBindTexture(GL_TEXTURE_2D, caps_.id());
    glUniform1i(program.uniform("u_caps"), caps_unit);
    glUniform1i(program.uniform("u_has_bake"), bake_res_ > 0 ? 1 : 0);
    glActiveTexture(GLenum(GL_TEXTURE0 + kBakeUnit));
    glBindTexture(GL_TEXTURE_2D, bake_lights_.id());
    glUniform1i(program.uniform("u_bake_lights"), kBakeUnit);
    glActiveTexture(GLenum(GL_TEXTURE0 + kBakeUnit + 1));
    glBindTexture(GL_TEXTURE_2D, bake_ambient_.id());
    glUniform1i(program.uniform("u_bake_ambient"), kBakeUnit + 1);
    if (bake_res_ > 0) {
        glUniform2f(program.uniform("u_bake_origin"), bake_origin_.x, bake_origin_.y);
        glUniform1f(program.uniform("u_bake_spacing"), bake_spacing_);
        glUniform1i(program.uniform("u_bake_res"), bake_res_);
    }
    glActiveTexture(GL_TEXTURE0);
}

void TableShadowPass::set_bake(const ShadowBake& bake) {
    const std::size_t n = std::size_t(bake.resolution) * std::size_t(bake.resolution) * 4;
    if (bake.resolution < 2 || bake.lights.size() != n || bake.ambient.size() != n)
        throw RuntimeError("shadow: a baked shadow of the wrong size");
    if (std::abs(bake.table_height - table_height_) > 1e-9)
        throw RuntimeError("shadow: the bake is for another table height");
    bake_lights_ = gl::make_float_texture(bake.resolution, bake.resolution, bake.lights.data());
    bake_ambient_ = gl::make_float_texture(bake.resolution, bake.resolution, bake.ambient.data());
    bake_res_ = bake.resolution;
    bake_open_beyond_ = bake.open_beyond;
    bake_origin_ = glm::vec2(float(bake.origin.x), float(bake.origin.y));
    bake_spacing_ = float(bake.spacing);
    gl::check_gl("uploading the baked shadow");
}

void TableShadowPass::draw(const glm::mat3& world_from_camera, const glm::vec2& tan_half_fov, const glm::vec3& eye) const {
    if (!program_) program_.emplace("fullscreen.vert", "render_shadow.frag");
    if (!target_) target_.emplace(width_, height_, 1);
    target_->bind();
    glViewport(0, 0, width_, height_);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    program_->use();
    glUniform2f(program_->uniform("u_size"), float(width_), float(height_));
    glUniform2f(program_->uniform("u_tan_half_fov"), tan_half_fov.x, tan_half_fov.y);
    glUniformMatrix3fv(program_->uniform("u_world_from_camera"), 1, GL_FALSE, glm::value_ptr(world_from_camera));
    set_uniforms(*program_, 0, eye);
    glBindVertexArray(empty_vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    gl::check_gl("drawing the table shadow");
}

std::vector<float> TableShadowPass::read() const {
    if (!target_) throw RuntimeError("shadow: read() before draw()");
    return gl::rows_top_first(target_->read(0), width_, height_);
}

}  // namespace glint::render
