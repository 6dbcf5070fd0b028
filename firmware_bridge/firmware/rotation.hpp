// Small vector and quaternion maths for the firmware (float) and the simulation (double).
// Hamilton quaternions q = w + xi + yj + zk; a unit quaternion q rotates v to q (0,v) q*.
// Header-only, no heap, only <cmath>.
#pragma once

#include <cmath>
#include <cstdint>

namespace glint::firmware {

template <typename T>
struct Vec3 {
    T x{}, y{}, z{};

    friend Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
    friend Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
    friend Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
    friend Vec3 operator*(T s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
    friend Vec3 operator*(Vec3 a, T s) { return {s * a.x, s * a.y, s * a.z}; }
    Vec3& operator+=(Vec3 b) { return *this = *this + b; }
    Vec3& operator-=(Vec3 b) { return *this = *this - b; }
    T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

template <typename T>
T dot(Vec3<T> a, Vec3<T> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <typename T>
Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
T norm(Vec3<T> a) { return std::sqrt(dot(a, a)); }

template <typename T>
struct Quat {
    T w{1}, x{}, y{}, z{};

    static Quat identity() { return {T(1), T(0), T(0), T(0)}; }
    // Rotation by `angle_rad` about the unit vector `axis` (right-hand rule).
    static Quat from_axis_angle(Vec3<T> axis, T angle_rad) {
        const T s = std::sin(angle_rad / 2);
        return {std::cos(angle_rad / 2), s * axis.x, s * axis.y, s * axis.z};
    }
    Vec3<T> vec() const { return {x, y, z}; }
    Quat conj() const { return {w, -x, -y, -z}; }
    friend Quat operator*(Quat a, Quat b) {
        return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
                a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
                a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
                a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
    }
    // q v q*, for a unit quaternion (expanded form: v + 2w (u x v) + 2 u x (u x v)).
    Vec3<T> rotate(Vec3<T> v) const {
        const Vec3<T> u = vec();
        const Vec3<T> t = T(2) * cross(u, v);
        return v + w * t + cross(u, t);
    }
    // q* v q: the inverse rotation.
    Vec3<T> rotate_inverse(Vec3<T> v) const { return conj().rotate(v); }
};

template <typename T>
T norm(Quat<T> q) { return std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z); }

// Unit quaternion with w >= 0 (the protocol asks senders for w >= 0; q and -q are one rotation).
// A zero or non-finite input gives the identity.
template <typename T>
Quat<T> normalized(Quat<T> q) {
    const T n = norm(q);
    if (!(n > T(0)) || !std::isfinite(n)) return Quat<T>::identity();
    const T s = (q.w < 0 ? T(-1) : T(1)) / n;
    return {q.w * s, q.x * s, q.y * s, q.z * s};
}

// Angle in radians of the rotation that takes a to b (0 .. pi), for unit quaternions.
template <typename T>
T angle_between(Quat<T> a, Quat<T> b) {
    const T d = std::fabs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z);
    return T(2) * std::acos(d > T(1) ? T(1) : d);
}

// q or -q, whichever lies in the same hemisphere as `reference` (non-negative dot product),
// so that interpolating from `reference` takes the short way round.
template <typename T>
Quat<T> same_hemisphere(Quat<T> q, Quat<T> reference) {
    const T d = q.w * reference.w + q.x * reference.x + q.y * reference.y + q.z * reference.z;
    return d < T(0) ? Quat<T>{-q.w, -q.x, -q.y, -q.z} : q;
}

// Rotation vector (axis * angle, angle in 0 .. pi) of a unit quaternion, the log map: q (taken
// with w >= 0) = (cos(angle/2), sin(angle/2) axis), so angle = 2 atan2(|vec|, w).
template <typename T>
Vec3<T> log_map(Quat<T> q) {
    if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
    const T s = norm(q.vec());
    if (s < T(1e-12)) return {};
    const T angle = T(2) * std::atan2(s, q.w);
    return (angle / s) * q.vec();
}

// Spherical linear interpolation between unit quaternions (constant angular velocity, the short
// way): t = 0 gives a, t = 1 gives b (up to sign). Nearly equal inputs return a.
template <typename T>
Quat<T> slerp(Quat<T> a, Quat<T> b, T t) {
    b = same_hemisphere(b, a);
    T d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
    if (d > T(1)) d = T(1);
    const T angle = std::acos(d);
    if (angle < T(1e-9)) return a;
    const T sa = std::sin(angle);
    const T wa = std::sin((T(1) - t) * angle) / sa;
    const T wb = std::sin(t * angle) / sa;
    return normalized(Quat<T>{wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y,
                              wa * a.z + wb * b.z});
}

template <typename T, typename U>
Quat<T> quat_cast(Quat<U> q) {
    return {static_cast<T>(q.w), static_cast<T>(q.x), static_cast<T>(q.y), static_cast<T>(q.z)};
}
template <typename T, typename U>
Vec3<T> vec_cast(Vec3<U> v) {
    return {static_cast<T>(v.x), static_cast<T>(v.y), static_cast<T>(v.z)};
}

using Vec3f = Vec3<float>;
using Quatf = Quat<float>;
using Vec3d = Vec3<double>;
using Quatd = Quat<double>;

// How a chip's axes sit on the board: sensor-frame axis i reads chip axis source[i] times
// sign[i]. Like the BNO055's AXIS_MAP_CONFIG/AXIS_MAP_SIGN, but applied in firmware so every
// chip on the board uses the same mechanism. A proper rotation needs an even permutation with
// an even number of negative signs, or an odd one with an odd number (checked by is_proper()).
struct AxisRemap {
    std::uint8_t source[3] = {0, 1, 2};
    std::int8_t sign[3] = {1, 1, 1};

    template <typename T>
    Vec3<T> to_sensor(Vec3<T> chip) const {
        return {static_cast<T>(sign[0]) * chip[source[0]], static_cast<T>(sign[1]) * chip[source[1]],
                static_cast<T>(sign[2]) * chip[source[2]]};
    }
    template <typename T>
    Vec3<T> to_chip(Vec3<T> sensor) const {
        T out[3] = {};
        out[source[0]] = static_cast<T>(sign[0]) * sensor.x;
        out[source[1]] = static_cast<T>(sign[1]) * sensor.y;
        out[source[2]] = static_cast<T>(sign[2]) * sensor.z;
        return {out[0], out[1], out[2]};
    }
    bool is_proper() const {
        if (source[0] > 2 || source[1] > 2 || source[2] > 2) return false;
        if (source[0] == source[1] || source[1] == source[2] || source[0] == source[2]) return false;
        // Permutation parity: (0 1 2), (1 2 0), (2 0 1) are even.
        const bool even = (source[1] == (source[0] + 1) % 3);
        int negatives = 0;
        for (std::int8_t s : sign) {
            if (s != 1 && s != -1) return false;
            negatives += s < 0 ? 1 : 0;
        }
        return even == (negatives % 2 == 0);
    }
    // The rotation that takes sensor-frame vectors to chip-frame vectors, as a quaternion
    // (from its rotation matrix; Shepperd's method picks the largest pivot for accuracy).
    Quatf sensor_to_chip() const;
};


// Glint's world frame (docs/conventions.md: +X right/east, +Y up, -Z forward/north) from the
// East-North-Up frame of chips such as the BNO055: x_g = east, y_g = up, z_g = -north, i.e. a
// rotation of -90 degrees about the shared x axis.
inline Quatf glint_world_from_enu() {
    const float h = 0.70710678118654752f;
    return {h, -h, 0.0f, 0.0f};
}

}  // namespace glint::firmware

namespace glint::firmware {

// Unit quaternion (w >= 0) of a proper rotation matrix m (row-major, v' = m v), by Shepperd's
// method: the largest of w, x, y, z is taken from the diagonal, the others from off-diagonal
// sums, so no division by a small number.
template <typename T>
Quat<T> quat_from_matrix(const T m[3][3]) {
    const T trace = m[0][0] + m[1][1] + m[2][2];
    Quat<T> q;
    if (trace > 0) {
        const T s = std::sqrt(trace + T(1)) * 2;
        q = {s / 4, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
    } else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
        const T s = std::sqrt(T(1) + m[0][0] - m[1][1] - m[2][2]) * 2;
        q = {(m[2][1] - m[1][2]) / s, s / 4, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
    } else if (m[1][1] >= m[2][2]) {
        const T s = std::sqrt(T(1) + m[1][1] - m[0][0] - m[2][2]) * 2;
        q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, s / 4, (m[1][2] + m[2][1]) / s};
    } else {
        const T s = std::sqrt(T(1) + m[2][2] - m[0][0] - m[1][1]) * 2;
        q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, s / 4};
    }
    return normalized(q);
}

inline Quatf AxisRemap::sensor_to_chip() const {
    // Column j of the matrix is the chip-frame image of sensor axis j.
    float m[3][3] = {};
    for (int j = 0; j < 3; ++j) m[source[j]][j] = static_cast<float>(sign[j]);
    return quat_from_matrix(m);
}

}  // namespace glint::firmware
