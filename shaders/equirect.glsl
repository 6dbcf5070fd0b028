// docs/conventions.md: texel (i, j) of a W x H map, row 0 at the top;
// phi = 2 pi (i + 0.5) / W - pi, theta = pi (j + 0.5) / H,
// d = (sin(theta) sin(phi), cos(theta), -sin(theta) cos(phi)).
const float PI = 3.14159265358979;
const float TWO_PI = 6.28318530717959;

float row_theta(int j, int h) { return PI * (float(j) + 0.5) / float(h); }
float column_phi(int i, int w) { return TWO_PI * (float(i) + 0.5) / float(w) - PI; }

// ln(1 - x) for 0 <= x < 1, accurate for small x (the weights of a narrow
// lobe are exp(n ln(1 - x)) with x = 1 - cos ~ 1/n: a plain log(1 - x) in
// float would lose n * 6e-8 of relative accuracy, 1e-3 at n = 20480).
float log1m(float x) {
    if (x < 0.01) {
        float x2 = x * x;
        return -x - 0.5 * x2 - x2 * x / 3.0 - 0.25 * x2 * x2;
    }
    return log(1.0 - x);
}

// 1 - cos(angle between the directions (tr, pr) and (tk, pk)), without
// cancellation: 2 sin^2(dt/2) + 2 sin(tr) sin(tk) sin^2(dp/2).
float one_minus_cos(float sin_half_dt, float sin_tr, float sin_tk, float sin_half_dp) {
    return 2.0 * sin_half_dt * sin_half_dt + 2.0 * sin_tr * sin_tk * sin_half_dp * sin_half_dp;
}
