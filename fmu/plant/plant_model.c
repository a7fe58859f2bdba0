/* plant_model.c: the reference robot's physics and sensors (see navkit_plant.h, docs/plant.md).
 *
 * Internal units are SI (m, m/s, rad, s, N, A, V); parameters and outputs carry the units
 * the variable table gives them. All state lives in plant_model_t.
 */
#include "navkit_plant.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
#define DEG (PI / 180.0) /* rad per deg */

void plant_set_start_values(plant_model_t *m)
{
    plant_release(m);
#define PLANT_START_NUM(n, c, s, u, d) m->v.n = (s);
#define PLANT_START_STR(n, c, s, u, d) snprintf(m->v.n, PLANT_STR_MAX, "%s", (s));
#define PLANT_START_BIN(n, c, s, u, d) /* outputs: empty until the model starts (released above) */
    PLANT_VARIABLES(PLANT_START_NUM, PLANT_START_NUM, PLANT_START_STR, PLANT_START_BIN)
#undef PLANT_START_NUM
#undef PLANT_START_STR
#undef PLANT_START_BIN
}

void plant_release(plant_model_t *m)
{
    free(m->walls);
    m->walls = NULL;
    m->n_walls = 0;
    free(m->v.walls.data);
    m->v.walls = (plant_binary_t){NULL, 0, 0};
}

/* ---------------------------------------------------------------- noise */

/* Next 64 random bits of stream s (splitmix64). */
static uint64_t rng_next(plant_model_t *m, int s)
{
    uint64_t z = (m->rng[s] += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in (0, 1) from stream s. */
static double rng_uniform(plant_model_t *m, int s)
{
    return ((double)(rng_next(m, s) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

/* Standard normal from stream s (Box-Muller, the second value cached). */
static double rng_normal(plant_model_t *m, int s)
{
    if (m->have_spare[s]) {
        m->have_spare[s] = 0;
        return m->spare[s];
    }
    double r = sqrt(-2.0 * log(rng_uniform(m, s)));
    double a = 2.0 * PI * rng_uniform(m, s);
    m->spare[s] = r * sin(a);
    m->have_spare[s] = 1;
    return r * cos(a);
}

enum { RNG_GYRO, RNG_COMPASS, RNG_IR, RNG_SONAR };

/* ---------------------------------------------------------------- world file */

/* Formats "file:line: message" (line 0: "file: message") into err; returns -1. */
static int world_error(char *err, size_t errlen, const char *file, int line, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (line > 0) {
        snprintf(err, errlen, "%s:%d: %s", file, line, msg);
    } else {
        snprintf(err, errlen, "%s: %s", file, msg);
    }
    return -1;
}

/* Appends a wall in file coordinates (mm); returns 0, or -1 when the world is full or
 * out of memory. *cap is the allocated count. */
static int add_wall(plant_model_t *m, size_t *cap, double ax, double ay, double bx, double by)
{
    if (m->n_walls == *cap) {
        size_t ncap = *cap ? *cap * 2 : 16;
        if (ncap > PLANT_MAX_WALLS) {
            ncap = PLANT_MAX_WALLS;
        }
        if (ncap == *cap) {
            return -1;
        }
        plant_wall_t *w = realloc(m->walls, ncap * sizeof *w);
        if (!w) {
            return -1;
        }
        m->walls = w;
        *cap = ncap;
    }
    m->walls[m->n_walls++] = (plant_wall_t){ax, ay, bx, by};
    return 0;
}

/* Stores x at p as 8 bytes: IEEE 754 binary64, little-endian (whatever the host's order). */
static void put_f64_le(uint8_t *p, double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    for (int i = 0; i < 8; i++) {
        p[i] = (uint8_t)(u >> (8 * i));
    }
}

/* Moves the n_walls walls from the file's frame (mm) into the start pose frame, whose
 * origin is the file's point (sx, sy) mm and whose x axis points at syaw deg: m->walls in
 * m, the walls output in mm (PLANT_WALL_BYTES a wall, never NULL once started). Returns 0,
 * or -1 with err set (naming file) when out of memory. */
static int place_walls(plant_model_t *m, double sx, double sy, double syaw, const char *file, char *err, size_t errlen)
{
    size_t nbytes = m->n_walls * PLANT_WALL_BYTES;
    uint8_t *out = malloc(nbytes ? nbytes : 1);
    if (!out) {
        return world_error(err, errlen, file, 0, "out of memory for %zu walls", m->n_walls);
    }
    double c = cos(syaw * DEG), s = sin(syaw * DEG);
    for (size_t i = 0; i < m->n_walls; i++) {
        plant_wall_t *w = &m->walls[i];
        double ax = w->ax - sx, ay = w->ay - sy, bx = w->bx - sx, by = w->by - sy;
        double mm[4] = {c * ax + s * ay, -s * ax + c * ay, c * bx + s * by, -s * bx + c * by};
        for (int k = 0; k < 4; k++) {
            put_f64_le(out + i * PLANT_WALL_BYTES + 8 * k, mm[k]);
        }
        *w = (plant_wall_t){1e-3 * mm[0], 1e-3 * mm[1], 1e-3 * mm[2], 1e-3 * mm[3]};
    }
    m->v.walls = (plant_binary_t){out, nbytes, nbytes};
    return 0;
}

/* Parses up to max numbers from s into v; returns how many, or -1 on a bad token. */
static int parse_numbers(char *s, double *v, int max)
{
    int n = 0;
    for (char *tok = strtok(s, " \t\r\n"); tok; tok = strtok(NULL, " \t\r\n")) {
        char *end;
        errno = 0;
        double x = strtod(tok, &end);
        if (*end != '\0' || errno == ERANGE || !isfinite(x)) {
            return -1;
        }
        if (n == max) {
            return max + 1;
        }
        v[n++] = x;
    }
    return n;
}

/* Loads m->v.world_file (empty = no walls) into m->walls, in the start pose frame, m,
 * and into the walls output (mm).
 * Format: docs/plant.md and config/worlds/README.md. Returns 0 or -1 with err set. */
static int load_world(plant_model_t *m, char *err, size_t errlen)
{
    const char *file = m->v.world_file;
    plant_release(m);
    if (file[0] == '\0') {
        return place_walls(m, 0.0, 0.0, 0.0, file, err, errlen);
    }
    FILE *f = fopen(file, "r");
    if (!f) {
        return world_error(err, errlen, file, 0, "cannot open world file (%s)", strerror(errno));
    }
    char line[4096];
    double v[65];
    double sx = 0, sy = 0, syaw = 0; /* mm, mm, deg: start pose in the file's frame */
    int have_start = 0, lineno = 0, rc = 0;
    size_t cap = 0;
    while (rc == 0 && fgets(line, sizeof line, f)) {
        lineno++;
        if (!strchr(line, '\n') && !feof(f)) {
            rc = world_error(err, errlen, file, lineno, "line longer than %zu bytes", sizeof line - 2);
            break;
        }
        char *hash = strchr(line, '#');
        if (hash) {
            *hash = '\0';
        }
        char *p = line + strspn(line, " \t\r\n");
        if (*p == '\0') {
            continue;
        }
        size_t kl = strcspn(p, " \t\r\n");
        char kw[16];
        snprintf(kw, sizeof kw, "%.*s", (int)(kl < 15 ? kl : 15), p);
        int n = parse_numbers(p + kl, v, 64);
        if (n < 0) {
            rc = world_error(err, errlen, file, lineno, "'%s': a value is not a finite number", kw);
        } else if (strcmp(kw, "wall") == 0 || strcmp(kw, "box") == 0) {
            if (n != 4) {
                rc = world_error(err, errlen, file, lineno, "'%s' takes 4 numbers (mm), got %d", kw, n);
            } else if (kw[0] == 'w') {
                if (v[0] == v[2] && v[1] == v[3]) {
                    rc = world_error(err, errlen, file, lineno, "wall has zero length");
                } else if (add_wall(m, &cap, v[0], v[1], v[2], v[3])) {
                    rc = world_error(err, errlen, file, lineno, "too many walls (at most %d)", PLANT_MAX_WALLS);
                }
            } else if (v[0] >= v[2] || v[1] >= v[3]) {
                rc = world_error(err, errlen, file, lineno, "box needs XMIN < XMAX and YMIN < YMAX");
            } else if (add_wall(m, &cap, v[0], v[1], v[2], v[1]) || add_wall(m, &cap, v[2], v[1], v[2], v[3]) ||
                       add_wall(m, &cap, v[2], v[3], v[0], v[3]) || add_wall(m, &cap, v[0], v[3], v[0], v[1])) {
                rc = world_error(err, errlen, file, lineno, "too many walls (at most %d)", PLANT_MAX_WALLS);
            }
        } else if (strcmp(kw, "polyline") == 0) {
            if (n < 4 || n % 2 != 0 || n > 64) {
                rc = world_error(
                    err, errlen, file, lineno,
                    "'polyline' takes 2 to 32 points (an even count of 4 to 64 numbers, mm), got %d numbers", n);
            } else {
                for (int i = 0; rc == 0 && i + 3 < n; i += 2) {
                    if (v[i] == v[i + 2] && v[i + 1] == v[i + 3]) {
                        rc = world_error(err, errlen, file, lineno, "polyline point %d repeats the one before",
                                         i / 2 + 2);
                    } else if (add_wall(m, &cap, v[i], v[i + 1], v[i + 2], v[i + 3])) {
                        rc = world_error(err, errlen, file, lineno, "too many walls (at most %d)", PLANT_MAX_WALLS);
                    }
                }
            }
        } else if (strcmp(kw, "start") == 0) {
            if (n != 3) {
                rc = world_error(err, errlen, file, lineno, "'start' takes X Y YAW (mm, mm, deg), got %d numbers", n);
            } else if (have_start) {
                rc = world_error(err, errlen, file, lineno, "second 'start' line");
            } else {
                sx = v[0];
                sy = v[1];
                syaw = v[2];
                have_start = 1;
            }
        } else {
            rc = world_error(err, errlen, file, lineno, "unknown keyword '%s' (expected wall, box, polyline or start)",
                             kw);
        }
    }
    if (rc == 0 && ferror(f)) {
        rc = world_error(err, errlen, file, 0, "read error");
    }
    fclose(f);
    if (rc) {
        plant_release(m);
        return rc;
    }
    if (place_walls(m, sx, sy, syaw, file, err, errlen)) {
        plant_release(m);
        return -1;
    }
    return 0;
}

/* ---------------------------------------------------------------- range sensors */

/* Distance (m) along the ray from (ox,oy) with unit direction (ux,uy) to the nearest
 * wall, or INFINITY. */
static double ray_cast(const plant_model_t *m, double ox, double oy, double ux, double uy)
{
    double best = INFINITY;
    for (size_t i = 0; i < m->n_walls; i++) {
        const plant_wall_t *w = &m->walls[i];
        double ex = w->bx - w->ax, ey = w->by - w->ay;
        double den = ux * ey - uy * ex; /* cross(u, e) */
        if (fabs(den) < 1e-12) {
            continue; /* parallel */
        }
        double px = w->ax - ox, py = w->ay - oy;
        double t = (px * ey - py * ex) / den; /* along the ray */
        double s = (px * uy - py * ux) / den; /* along the wall, 0..1 */
        if (t > 0.0 && t < best && s >= 0.0 && s <= 1.0) {
            best = t;
        }
    }
    return best;
}

/* Clip the segment parameter range [*t0, *t1] (0..1 along the wall) to the points
 * where fa + fe * t >= 0 (fa, fe in m^2: a cone edge's inward normal dotted with the
 * wall start and the wall vector); false when no point of the wall qualifies because
 * it runs parallel to the edge on the outside. */
static bool clip_half_plane(double fa, double fe, double *t0, double *t1)
{
    if (fe == 0.0) {
        return !(fa < 0.0);
    }
    double t = -fa / fe;
    if (fe > 0.0) {
        if (t > *t0) {
            *t0 = t;
        }
    } else if (t < *t1) {
        *t1 = t;
    }
    return true;
}

/* Distance (m) from (ox,oy) to the nearest wall point inside the cone of half-angle
 * h (cos ch, sin sh < 90 deg) around unit direction (ux,uy), or INFINITY: the first
 * echo of a rough wall (nearer walls hide farther ones by being nearer). */
static double cone_cast(const plant_model_t *m, double ox, double oy, double ux, double uy, double ch, double sh)
{
    /* inward normals of the cone's edges: edge at +h rotated -90 deg, edge at -h rotated +90 deg */
    double lx = ux * ch - uy * sh, ly = uy * ch + ux * sh; /* left edge direction */
    double rx = ux * ch + uy * sh, ry = uy * ch - ux * sh; /* right edge direction */
    double n1x = ly, n1y = -lx, n2x = -ry, n2y = rx;
    double best2 = INFINITY;
    for (size_t i = 0; i < m->n_walls; i++) {
        const plant_wall_t *w = &m->walls[i];
        double ax = w->ax - ox, ay = w->ay - oy;
        double ex = w->bx - w->ax, ey = w->by - w->ay;
        double t0 = 0.0, t1 = 1.0;
        if (!clip_half_plane(n1x * ax + n1y * ay, n1x * ex + n1y * ey, &t0, &t1) ||
            !clip_half_plane(n2x * ax + n2y * ay, n2x * ex + n2y * ey, &t0, &t1) || t0 > t1) {
            continue;
        }
        double tp = -(ax * ex + ay * ey) / (ex * ex + ey * ey); /* foot of the perpendicular */
        if (tp < t0) {
            tp = t0;
        }
        if (tp > t1) {
            tp = t1;
        }
        double px = ax + tp * ex, py = ay + tp * ey;
        double d2 = px * px + py * py;
        if (d2 < best2) {
            best2 = d2;
        }
    }
    return sqrt(best2);
}

/* Sensor pose in the start frame from a body mount: origin (*ox,*oy) m, direction (*ux,*uy). */
static void mount_pose(const plant_model_t *m, const plant_mount_t *mt, double *ox, double *oy, double *ux, double *uy)
{
    double c = cos(m->yaw), s = sin(m->yaw);
    *ox = m->xm + c * mt->x - s * mt->y;
    *oy = m->ym + s * mt->x + c * mt->y;
    *ux = c * mt->ux - s * mt->uy;
    *uy = s * mt->ux + c * mt->uy;
}

/* GP2D12 output (V, without noise) for a wall at d m (INFINITY = none). */
static double ir_curve(const plant_values_t *v, double d)
{
    double dmm = d * 1000.0;
    if (dmm > v->ir_far_mm) {
        dmm = v->ir_far_mm;
    }
    if (dmm >= v->ir_peak_mm) {
        return v->ir_a_v_mm / (dmm + v->ir_b_mm) + v->ir_c_v;
    }
    double vpeak = v->ir_a_v_mm / (v->ir_peak_mm + v->ir_b_mm) + v->ir_c_v;
    return vpeak * dmm / v->ir_peak_mm;
}

/* Takes a reading of every IR ranger at the current pose. */
static void read_ir(plant_model_t *m)
{
    double *out[PLANT_N_IR] = {&m->v.ir_voltage_0, &m->v.ir_voltage_1, &m->v.ir_voltage_2, &m->v.ir_voltage_3};
    for (int i = 0; i < PLANT_N_IR; i++) {
        double ox, oy, ux, uy;
        mount_pose(m, &m->k.ir[i], &ox, &oy, &ux, &uy);
        double volt = ir_curve(&m->v, ray_cast(m, ox, oy, ux, uy)) + m->v.ir_noise_v * rng_normal(m, RNG_IR);
        *out[i] = volt > 0.0 ? volt : 0.0;
    }
}

/* Pings every sonar at the current pose. */
static void read_sonar(plant_model_t *m)
{
    double *out[PLANT_N_SONAR] = {&m->v.sonar_echo_0, &m->v.sonar_echo_1, &m->v.sonar_echo_2, &m->v.sonar_echo_3};
    for (int i = 0; i < PLANT_N_SONAR; i++) {
        double ox, oy, ux, uy;
        mount_pose(m, &m->k.sonar[i], &ox, &oy, &ux, &uy);
        double d = cone_cast(m, ox, oy, ux, uy, m->k.sonar_cos_half, m->k.sonar_sin_half);
        double noise = m->v.sonar_noise_us * rng_normal(m, RNG_SONAR); /* drawn always: stream stays aligned */
        if (d * 1000.0 > m->v.sonar_max_mm) {
            *out[i] = 0.0;
        } else {
            if (d * 1000.0 < m->v.sonar_min_mm) {
                d = m->v.sonar_min_mm * 1e-3;
            }
            double us = d * m->k.us_per_m + noise;
            *out[i] = us > 1.0 ? us : 1.0;
        }
    }
}

/* ---------------------------------------------------------------- outputs */

/* dio_in from the DIO inputs and the input pattern (12 pins). */
static void update_dio(plant_model_t *m)
{
    m->v.dio_in = ((m->v.dio_out & m->v.dio_dir) | (m->v.dio_input_pattern & ~m->v.dio_dir)) & 0xFFF;
}

void plant_inputs_changed(plant_model_t *m)
{
    update_dio(m);
}

/* fmod(x, 360.0) bit for bit, without the libm call for |x| < 16 turns (every step but
 * after a very long spin): fmod is exact, |x| - n 360 with the sign of x (a zero result
 * too), so below 360 it is x itself. Taking 2880, 1440, 720 and 360 deg off |x| where
 * they fit gives that n: each subtraction is exact (a in [y, 2y), Sterbenz) and leaves a
 * below y. NaN and larger values go to fmod. */
static double fmod360(double x)
{
    double a = fabs(x);
    if (a < 360.0) {
        return x; /* most steps */
    }
    if (!(a < 16.0 * 360.0)) {
        return fmod(x, 360.0);
    }
    for (double y = 8.0 * 360.0; y >= 360.0; y *= 0.5) {
        if (a >= y) {
            a -= y;
        }
    }
    return copysign(a, x);
}

/* Computes the sampled outputs (encoders, gyro, compass, battery, truth, DIO) from the
 * state; draws the gyro and compass noise. */
static void update_outputs(plant_model_t *m)
{
    plant_values_t *v = &m->v;
    double w = (m->vw[1] - m->vw[0]) / m->k.track; /* rad/s, CCW */
    v->x_mm = m->xm * 1000.0;
    v->y_mm = m->ym * 1000.0;
    v->yaw_deg = m->yaw / DEG;
    double hdg = fmod360(-v->yaw_deg);
    if (hdg < 0.0) {
        hdg += 360.0;
    }
    if (hdg >= 360.0 || hdg == 0.0) {
        hdg = 0.0; /* also turns -0 into +0 */
    }
    v->heading_deg = hdg;
    v->distance_mm = 500.0 * (m->sw[0] + m->sw[1]);
    v->v_mm_s = 500.0 * (m->vw[0] + m->vw[1]);
    v->w_deg_s = w / DEG;
    v->enc_left = (int32_t)floor(m->sw[0] * m->k.counts_per_m[0]);
    v->enc_right = (int32_t)floor(m->sw[1] * m->k.counts_per_m[1]);
    double g = (v->w_deg_s + m->gyro_bias + v->gyro_noise_dps * rng_normal(m, RNG_GYRO)) * v->gyro_lsb_per_dps;
    g = floor(g + 0.5);
    v->gyro_raw = (int32_t)(g > 32767.0 ? 32767.0 : g < -32768.0 ? -32768.0 : g);
    double bearing = fmod360(v->compass_start_deg + hdg + v->compass_noise_deg * rng_normal(m, RNG_COMPASS));
    if (bearing < 0.0) {
        bearing += 360.0;
    }
    v->compass_raw = (int32_t)floor(bearing * 10.0 + 0.5) % 3600;
    v->battery_voltage = m->vbat;
    update_dio(m);
}

/* ---------------------------------------------------------------- start */

/* Checks that parameter name's value v lies in [lo, hi]; formats err and returns -1 if not. */
static int check_range(const char *name, double v, double lo, double hi, char *err, size_t errlen)
{
    if (v >= lo && v <= hi && isfinite(v)) {
        return 0;
    }
    snprintf(err, errlen, "parameter %s = %g is out of range [%g, %g]", name, v, lo, hi);
    return -1;
}

int plant_start(plant_model_t *m, double t0, char *err, size_t errlen)
{
    plant_values_t *v = &m->v;
    const double BIG = 1e12;
#define PLANT_CHECK(name, lo, hi)                                                                                      \
    do {                                                                                                               \
        if (check_range(#name, (double)v->name, lo, hi, err, errlen)) {                                                \
            return -1;                                                                                                 \
        }                                                                                                              \
    } while (0)
    PLANT_CHECK(wheel_diameter_mm, 1.0, BIG);
    PLANT_CHECK(wheel_scale_left, 0.1, 10.0);
    PLANT_CHECK(wheel_scale_right, 0.1, 10.0);
    PLANT_CHECK(track_width_mm, 1.0, BIG);
    PLANT_CHECK(encoder_counts_per_rev, 1, 1e9);
    PLANT_CHECK(mass_kg, 1e-3, BIG);
    PLANT_CHECK(yaw_inertia_kg_m2, 1e-6, BIG);
    PLANT_CHECK(gear_ratio, 1e-3, BIG);
    PLANT_CHECK(motor_r_ohm, 1e-6, BIG);
    PLANT_CHECK(motor_kt_nm_a, 0.0, BIG);
    PLANT_CHECK(motor_ke_v_s_rad, 0.0, BIG);
    PLANT_CHECK(motor_i_max_a, 0.0, BIG);
    PLANT_CHECK(motor_rotor_inertia_kg_m2, 0.0, BIG);
    PLANT_CHECK(friction_coulomb_n, 0.0, BIG);
    PLANT_CHECK(friction_viscous_n_s_m, 0.0, BIG);
    PLANT_CHECK(battery_ocv_v, 0.0, BIG);
    PLANT_CHECK(battery_empty_v, 0.0, v->battery_ocv_v);
    PLANT_CHECK(battery_capacity_ah, 1e-9, BIG);
    PLANT_CHECK(battery_r_ohm, 0.0, BIG);
    PLANT_CHECK(battery_idle_a, 0.0, BIG);
    PLANT_CHECK(gyro_lsb_per_dps, 1e-6, BIG);
    PLANT_CHECK(gyro_bias_dps, -BIG, BIG);
    PLANT_CHECK(gyro_bias_walk_dps_rt_s, 0.0, BIG);
    PLANT_CHECK(gyro_noise_dps, 0.0, BIG);
    PLANT_CHECK(compass_start_deg, -BIG, BIG);
    PLANT_CHECK(compass_noise_deg, 0.0, BIG);
    PLANT_CHECK(servo_center_us, 0.0, BIG);
    PLANT_CHECK(servo_rate_dps, 1e-6, BIG);
    PLANT_CHECK(servo_travel_deg, 0.0, 360.0);
    PLANT_CHECK(ir_b_mm, 0.0, BIG);
    PLANT_CHECK(ir_peak_mm, 1.0, BIG);
    PLANT_CHECK(ir_far_mm, v->ir_peak_mm, BIG);
    PLANT_CHECK(ir_noise_v, 0.0, BIG);
    PLANT_CHECK(ir_period_ms, 1e-3, BIG);
    PLANT_CHECK(sonar_min_mm, 0.0, BIG);
    PLANT_CHECK(sonar_max_mm, v->sonar_min_mm, BIG);
    PLANT_CHECK(sonar_beam_deg, 0.0, 179.0);
    PLANT_CHECK(sound_speed_m_s, 1.0, BIG);
    PLANT_CHECK(sonar_noise_us, 0.0, BIG);
    PLANT_CHECK(sonar_period_ms, 1e-3, BIG);
#undef PLANT_CHECK
    if (v->servo_us_per_deg == 0.0 || !isfinite(v->servo_us_per_deg)) {
        snprintf(err, errlen, "parameter servo_us_per_deg must be finite and not 0");
        return -1;
    }
    if (load_world(m, err, errlen)) {
        return -1;
    }

    plant_derived_t *k = &m->k;
    double scale[2] = {v->wheel_scale_left, v->wheel_scale_right};
    double a = 1.0 / v->mass_kg, bw;
    k->track = v->track_width_mm * 1e-3;
    bw = k->track * k->track / (4.0 * v->yaw_inertia_kg_m2);
    /* body: wheel accelerations = [[a+bw, a-bw], [a-bw, a+bw]] * wheel forces; invert it */
    double p = a + bw, q = a - bw, det = p * p - q * q;
    for (int i = 0; i < 2; i++) {
        k->r[i] = 0.5e-3 * v->wheel_diameter_mm * scale[i];
        k->g[i] = v->gear_ratio / k->r[i];
        k->counts_per_m[i] = v->encoder_counts_per_rev / (2.0 * PI * k->r[i]);
        k->kt[i] = v->motor_kt_nm_a * k->g[i];
        k->ke[i] = v->motor_ke_v_s_rad * k->g[i];
        k->damp_emf[i] = k->kt[i] * k->ke[i] / v->motor_r_ohm + v->friction_viscous_n_s_m;
    }
    k->mass[0][0] = p / det + v->motor_rotor_inertia_kg_m2 * k->g[0] * k->g[0];
    k->mass[1][1] = p / det + v->motor_rotor_inertia_kg_m2 * k->g[1] * k->g[1];
    k->mass[0][1] = k->mass[1][0] = -q / det;
    k->ir_period = v->ir_period_ms * 1e-3;
    k->sonar_period = v->sonar_period_ms * 1e-3;
    k->sonar_cos_half = cos(0.5 * v->sonar_beam_deg * DEG);
    k->sonar_sin_half = sin(0.5 * v->sonar_beam_deg * DEG);
    k->us_per_m = 2.0e6 / v->sound_speed_m_s;
    double mounts[PLANT_N_IR + PLANT_N_SONAR][3] = {
        {v->ir_x_mm_0, v->ir_y_mm_0, v->ir_angle_deg_0},
        {v->ir_x_mm_1, v->ir_y_mm_1, v->ir_angle_deg_1},
        {v->ir_x_mm_2, v->ir_y_mm_2, v->ir_angle_deg_2},
        {v->ir_x_mm_3, v->ir_y_mm_3, v->ir_angle_deg_3},
        {v->sonar_x_mm_0, v->sonar_y_mm_0, v->sonar_angle_deg_0},
        {v->sonar_x_mm_1, v->sonar_y_mm_1, v->sonar_angle_deg_1},
        {v->sonar_x_mm_2, v->sonar_y_mm_2, v->sonar_angle_deg_2},
        {v->sonar_x_mm_3, v->sonar_y_mm_3, v->sonar_angle_deg_3},
    };
    for (int i = 0; i < PLANT_N_IR + PLANT_N_SONAR; i++) {
        plant_mount_t *mt = i < PLANT_N_IR ? &k->ir[i] : &k->sonar[i - PLANT_N_IR];
        mt->x = mounts[i][0] * 1e-3;
        mt->y = mounts[i][1] * 1e-3;
        mt->ux = cos(mounts[i][2] * DEG);
        mt->uy = sin(mounts[i][2] * DEG);
    }

    m->t = t0;
    v->time = t0;
    m->step_h = 0.0; /* no step size seen: plant_step works its sub-steps out */
    m->w_h = 0.0;    /* no W yet: the first sub-step computes it */
    m->xm = m->ym = m->yaw = 0.0;
    m->vw[0] = m->vw[1] = m->sw[0] = m->sw[1] = m->fc[0] = m->fc[1] = 0.0;
    m->charge_ah = 0.0;
    m->vbat = v->battery_ocv_v - v->battery_r_ohm * v->battery_idle_a;
    m->gyro_bias = v->gyro_bias_dps;
    for (int s = 0; s < 4; s++) {
        m->rng[s] = (uint64_t)(uint32_t)v->seed * 0x2545F4914F6CDD1Dull + (uint64_t)(s + 1) * 0x9E3779B97F4A7C15ull;
        m->have_spare[s] = 0;
        m->spare[s] = 0.0;
    }
    double *servo[PLANT_N_SERVO] = {&v->servo_deg_0, &v->servo_deg_1, &v->servo_deg_2, &v->servo_deg_3,
                                    &v->servo_deg_4, &v->servo_deg_5, &v->servo_deg_6, &v->servo_deg_7};
    for (int i = 0; i < PLANT_N_SERVO; i++) {
        *servo[i] = 0.0;
    }
    read_ir(m);
    read_sonar(m);
    m->next_ir = t0 + k->ir_period;
    m->next_sonar = t0 + k->sonar_period;
    update_outputs(m);
    return 0;
}

/* ---------------------------------------------------------------- dynamics */

/* Clamps x to [-lim, lim]; NaN becomes 0. */
static double clampd(double x, double lim)
{
    if (!(x == x)) {
        return 0.0;
    }
    return x > lim ? lim : x < -lim ? -lim : x;
}

/* One sub-step of h seconds: motors, drive train with Coulomb friction, battery, pose. */
static void substep(plant_model_t *m, double h)
{
    const plant_values_t *v = &m->v;
    const plant_derived_t *k = &m->k;
    double duty[2] = {clampd(v->motor_left_duty, 1.0), clampd(v->motor_right_duty, 1.0)};
    double f0[2], damp[2];
    for (int i = 0; i < 2; i++) {
        double kt = k->kt[i], ke = k->ke[i]; /* N/A, V/(m/s) */
        double va = duty[i] * m->vbat;
        double amps = (va - ke * m->vw[i]) / v->motor_r_ohm;
        if (fabs(amps) > v->motor_i_max_a) { /* current limit: constant force */
            f0[i] = kt * (amps > 0 ? v->motor_i_max_a : -v->motor_i_max_a);
            damp[i] = v->friction_viscous_n_s_m;
        } else { /* back-EMF damping taken implicitly */
            f0[i] = kt * va / v->motor_r_ohm;
            damp[i] = k->damp_emf[i];
        }
    }
    /* (M + h D) v' = M v + h (F0 - Fc);  W = h (M + h D)^-1, a function of h and D alone:
     * computed again only when their bits change (a motor entering or leaving its current
     * limit), else the same values come from the last sub-step */
    if (memcmp(&h, &m->w_h, sizeof h) != 0 || memcmp(damp, m->w_damp, sizeof damp) != 0) {
        double a00 = k->mass[0][0] + h * damp[0], a11 = k->mass[1][1] + h * damp[1], a01 = k->mass[0][1];
        double det = a00 * a11 - a01 * a01;
        m->w00 = h * a11 / det;
        m->w11 = h * a00 / det;
        m->w01 = -h * a01 / det;
        m->w_h = h;
        memcpy(m->w_damp, damp, sizeof damp);
    }
    double w00 = m->w00, w11 = m->w11, w01 = m->w01;
    double r0 = (k->mass[0][0] * m->vw[0] + k->mass[0][1] * m->vw[1]) / h + f0[0];
    double r1 = (k->mass[1][0] * m->vw[0] + k->mass[1][1] * m->vw[1]) / h + f0[1];
    double vf0 = w00 * r0 + w01 * r1, vf1 = w01 * r0 + w11 * r1; /* speeds without Coulomb */
    /* Coulomb friction: box-constrained, projected Gauss-Seidel (sticks when it can) */
    double fc0 = m->fc[0], fc1 = m->fc[1], lim = v->friction_coulomb_n;
    for (int it = 0; it < 4; it++) {
        double fc1_in = fc1;
        fc0 = clampd((vf0 - w01 * fc1) / w00, lim);
        fc1 = clampd((vf1 - w01 * fc0) / w11, lim);
        /* an iteration is a function of fc1 alone: when it gives back fc1's bits, the ones
         * left would repeat it exactly (a wheel stuck or at the force limit: most steps) */
        if (memcmp(&fc1, &fc1_in, sizeof fc1) == 0) {
            break;
        }
    }
    m->fc[0] = fc0;
    m->fc[1] = fc1;
    double vn[2] = {vf0 - w00 * fc0 - w01 * fc1, vf1 - w01 * fc0 - w11 * fc1};
    if (fabs(vn[0]) < 1e-9) {
        vn[0] = 0.0; /* m/s: what the iterations leave of a stuck wheel */
    }
    if (fabs(vn[1]) < 1e-9) {
        vn[1] = 0.0;
    }

    /* battery: the H-bridge draws duty * motor current */
    double ibat = v->battery_idle_a;
    for (int i = 0; i < 2; i++) {
        double amps = clampd((duty[i] * m->vbat - k->ke[i] * vn[i]) / v->motor_r_ohm, v->motor_i_max_a);
        ibat += duty[i] * amps;
    }
    m->charge_ah += ibat * h / 3600.0;
    double ocv = v->battery_ocv_v - (v->battery_ocv_v - v->battery_empty_v) * m->charge_ah / v->battery_capacity_ah;
    if (ocv < 0.0) {
        ocv = 0.0;
    }
    m->vbat = ocv - v->battery_r_ohm * ibat;
    if (m->vbat < 0.0) {
        m->vbat = 0.0;
    }

    /* pose and wheel travel (trapezoidal speeds, midpoint heading) */
    double dl = 0.5 * (m->vw[0] + vn[0]) * h, dr = 0.5 * (m->vw[1] + vn[1]) * h;
    double ds = 0.5 * (dl + dr), dyaw = (dr - dl) / k->track;
    double ymid = m->yaw + 0.5 * dyaw;
    /* A standing robot (ds == 0) skips the trig: x + (+-0 * finite) is x bit for bit, as
     * xm and ym start at +0 and a sum is -0 only when both terms are. A non-finite ymid
     * still takes the full path, so its NaN reaches the pose. */
    if (ds != 0.0 || !isfinite(ymid)) {
        m->xm += ds * cos(ymid);
        m->ym += ds * sin(ymid);
    }
    m->yaw += dyaw;
    m->sw[0] += dl;
    m->sw[1] += dr;
    m->vw[0] = vn[0];
    m->vw[1] = vn[1];
}

/* Where each servo's pulse input (us) and angle output (deg) lie in plant_values_t. */
static const size_t servo_pulse_at[PLANT_N_SERVO] = {
    offsetof(plant_values_t, servo_pulse_0), offsetof(plant_values_t, servo_pulse_1),
    offsetof(plant_values_t, servo_pulse_2), offsetof(plant_values_t, servo_pulse_3),
    offsetof(plant_values_t, servo_pulse_4), offsetof(plant_values_t, servo_pulse_5),
    offsetof(plant_values_t, servo_pulse_6), offsetof(plant_values_t, servo_pulse_7)};
static const size_t servo_deg_at[PLANT_N_SERVO] = {
    offsetof(plant_values_t, servo_deg_0), offsetof(plant_values_t, servo_deg_1), offsetof(plant_values_t, servo_deg_2),
    offsetof(plant_values_t, servo_deg_3), offsetof(plant_values_t, servo_deg_4), offsetof(plant_values_t, servo_deg_5),
    offsetof(plant_values_t, servo_deg_6), offsetof(plant_values_t, servo_deg_7)};

/* Moves every servo toward its commanded angle, at most servo_rate_dps for h seconds. */
static void step_servos(plant_model_t *m, double h)
{
    plant_values_t *v = &m->v;
    double maxd = v->servo_rate_dps * h;
    for (int i = 0; i < PLANT_N_SERVO; i++) {
        double pulse = *(const double *)(const void *)((const char *)v + servo_pulse_at[i]);
        double *deg = (double *)(void *)((char *)v + servo_deg_at[i]);
        if (!(pulse > 0.0)) {
            continue; /* not driven: holds */
        }
        double target = clampd((pulse - v->servo_center_us) / v->servo_us_per_deg, v->servo_travel_deg);
        *deg += clampd(target - *deg, maxd);
    }
}

/* Whether a sensor sampled every period s, next due at *next s, takes a reading at time
 * t s (1 ns early counts as due); if so, moves *next one period on (past t if it lags). */
static bool sample_due(double *next, double t, double period)
{
    if (!(t >= *next - 1e-9)) {
        return false;
    }
    *next += period;
    if (*next <= t) {
        *next = t + period;
    }
    return true;
}

void plant_step(plant_model_t *m, double h)
{
    if (!(h == m->step_h)) { /* the importer's step size is the same every step */
        int sub = (int)ceil(h / PLANT_MAX_SUBSTEP_S - 1e-9);
        m->step_n = sub < 1 ? 1 : sub;
        m->step_hs = h / m->step_n;
        m->step_sqrt_h = sqrt(h);
        m->step_h = h;
    }
    int n = m->step_n;
    double hs = m->step_hs;
    for (int i = 0; i < n; i++) {
        substep(m, hs);
        m->t += hs;
        if (sample_due(&m->next_ir, m->t, m->k.ir_period)) {
            read_ir(m);
        }
        if (sample_due(&m->next_sonar, m->t, m->k.sonar_period)) {
            read_sonar(m);
        }
    }
    step_servos(m, h);
    m->gyro_bias += m->v.gyro_bias_walk_dps_rt_s * m->step_sqrt_h * rng_normal(m, RNG_GYRO);
    m->v.time = m->t;
    update_outputs(m);
}
