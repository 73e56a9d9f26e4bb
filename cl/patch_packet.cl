/* rc_intersect_patch_box (patch.cl) for the 16 rays of a fragment-style packet (classified.cl's
 * RcLanes16) against one patch box: the same operations lane by lane, each lane's iteration
 * frozen by select once it has stopped, and each restart run for the lanes without a hit yet, so
 * every lane ends where the scalar routine ends. */
#include "patch.cl"
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF

RC_DEFINE_BERNSTEIN3(RC_SHADE_INLINE, rc_bernstein3_16, float16)

/* rc_patch_channel per lane: value, derivative along s, along t. */
RC_SHADE_INLINE void rc_patch_channel16(const float16* c, const float16* bu, const float16* dbu,
                                        const float16* bv, const float16* dbv, float16* x,
                                        float16* xs, float16* xt) {
    *x = 0.0f;
    *xs = 0.0f;
    *xt = 0.0f;
    for (int i = 0; i < 4; ++i) {
        const float16 row =
            bv[0] * c[4 * i] + bv[1] * c[4 * i + 1] + bv[2] * c[4 * i + 2] + bv[3] * c[4 * i + 3];
        const float16 rowD = dbv[0] * c[4 * i] + dbv[1] * c[4 * i + 1] + dbv[2] * c[4 * i + 2] +
                             dbv[3] * c[4 * i + 3];
        *x += bu[i] * row;
        *xs += dbu[i] * row;
        *xt += bu[i] * rowD;
    }
}

/* The same for the weights, which every lane shares. */
RC_SHADE_INLINE void rc_patch_weights16(const float* c, const float16* bu, const float16* dbu,
                                        const float16* bv, const float16* dbv, float16* x,
                                        float16* xs, float16* xt) {
    *x = 0.0f;
    *xs = 0.0f;
    *xt = 0.0f;
    for (int i = 0; i < 4; ++i) {
        const float16 row =
            bv[0] * c[4 * i] + bv[1] * c[4 * i + 1] + bv[2] * c[4 * i + 2] + bv[3] * c[4 * i + 3];
        const float16 rowD = dbv[0] * c[4 * i] + dbv[1] * c[4 * i + 1] + dbv[2] * c[4 * i + 2] +
                             dbv[3] * c[4 * i + 3];
        *x += bu[i] * row;
        *xs += dbu[i] * row;
        *xt += bu[i] * rowD;
    }
}

/* rc_patch_half_curve per lane (`upper` the same for all). */
RC_DEFINE_HALF_CURVE(RC_SHADE_INLINE, rc_patch_half_curve16, float16)

/* rc_patch_quarter_straddles per lane. */
RC_SHADE_INLINE int16 rc_patch_quarter_straddles16(const float16* x, int qu, int qv) {
    float16 h[16];
    for (int j = 0; j < 4; ++j) {
        float16 q[4];
        rc_patch_half_curve16(x[j], x[4 + j], x[8 + j], x[12 + j], qu, q);
        for (int i = 0; i < 4; ++i) h[4 * i + j] = q[i];
    }
    int16 pos = 0, neg = 0;
    for (int i = 0; i < 4; ++i) {
        float16 q[4];
        rc_patch_half_curve16(h[4 * i], h[4 * i + 1], h[4 * i + 2], h[4 * i + 3], qv, q);
        for (int j = 0; j < 4; ++j) {
            pos |= q[j] >= 0.0f;
            neg |= q[j] <= 0.0f;
        }
    }
    return pos & neg;
}

/* rc_patch_newton_search for the lanes `run` from (*s, *t): the lanes that converged; (*s, *t)
 * where each lane's search stopped. */
RC_SHADE_INLINE int16 rc_packet_patch_search(const float16* a, const float16* b, const float* w,
                                             float16 eps, int16 run, float16* sIo, float16* tIo) {
    float16 s = *sIo, t = *tIo, prev = INFINITY;
    int16 converged = 0;
    float16 bu[4], dbu[4], bv[4], dbv[4];
    for (int it = 0;; ++it) {
        rc_bernstein3_16(s, bu, dbu);
        rc_bernstein3_16(t, bv, dbv);
        float16 A, As, At, B, Bs, Bt, W, Ws, Wt;
        rc_patch_channel16(a, bu, dbu, bv, dbv, &A, &As, &At);
        rc_patch_channel16(b, bu, dbu, bv, dbv, &B, &Bs, &Bt);
        rc_patch_weights16(w, bu, dbu, bv, dbv, &W, &Ws, &Wt);
        const float16 f1 = A / W, f2 = B / W;
        const float16 err = fmax(fabs(f1), fabs(f2));
        const int16 conv = run & (err < eps);
        converged |= conv;
        run &= ~conv;
        run &= ~(~(err <= prev) | (it == RC_PATCH_ITERATIONS ? (int16)(-1) : (int16)(0)));
        if (!any(run)) break;
        prev = select(prev, err, run);
        const float16 j11 = (As - f1 * Ws) / W, j12 = (At - f1 * Wt) / W;
        const float16 j21 = (Bs - f2 * Ws) / W, j22 = (Bt - f2 * Wt) / W;
        const float16 det = j11 * j22 - j12 * j21;
        const int16 regular = fabs(det) > 1e-7f * (fabs(j11 * j22) + fabs(j12 * j21));
        const float16 sNewton = s - (j22 * f1 - j12 * f2) / det;
        const float16 tNewton = t - (j11 * f2 - j21 * f1) / det;
        const float16 sNudge = s + select((float16)(-0.125f), (float16)(0.125f), s <= 0.5f);
        const float16 tNudge = t + select((float16)(-0.0625f), (float16)(0.0625f), t <= 0.5f);
        s = select(s, select(sNudge, sNewton, regular), run);
        t = select(t, select(tNudge, tNewton, regular), run);
        prev = select(prev, (float16)(INFINITY), run & ~regular);
        run &= (s > -0.5f) & (s < 1.5f) & (t > -0.5f) & (t < 1.5f);
        if (!any(run)) break;
    }
    *sIo = s;
    *tIo = t;
    return converged;
}

/* The lanes that hit the box in (tmin, tmax), with t and the local (u, v). */
RC_SHADE_INLINE int16 rc_packet_patch(const RcLanes16* L, __global const float4* analytic,
                                      __global const RcPatchBox* box, float16 tmax, float16* tOut,
                                      float16* uOut, float16* vOut) {
    const float16 Dx = L->dx, Dy = L->dy, Dz = L->dz;
    /* rc_patch_planes */
    const int16 alongX = (fabs(Dx) > fabs(Dy)) & (fabs(Dx) > fabs(Dz));
    float16 nx = select((float16)(0.0f), Dy, alongX);
    float16 ny = select(Dz, -Dx, alongX);
    float16 nz = select(-Dy, (float16)(0.0f), alongX);
    const float16 len = sqrt(nx * nx + ny * ny + nz * nz);
    nx = nx / len;
    ny = ny / len;
    nz = nz / len;
    const float16 mx = Dy * nz - ny * Dz, my = Dz * nx - nz * Dx, mz = Dx * ny - nx * Dy;
    __global const float4* pts = analytic + box->points;
    float16 a[16], b[16];
    float w[16];
    float16 spread = 0.0f;
    float wMin = INFINITY;
    int16 aPos = 0, aNeg = 0, bPos = 0, bNeg = 0;
    for (int k = 0; k < 16; ++k) {
        const float4 p = pts[k];
        const float16 rx = p.x - L->ox * p.w, ry = p.y - L->oy * p.w, rz = p.z - L->oz * p.w;
        a[k] = nx * rx + ny * ry + nz * rz;
        b[k] = mx * rx + my * ry + mz * rz;
        w[k] = p.w;
        spread = fmax(spread, fabs(a[k]) + fabs(b[k]));
        wMin = fmin(wMin, p.w);
        aPos |= a[k] > 0.0f;
        aNeg |= a[k] < 0.0f;
        bPos |= b[k] > 0.0f;
        bNeg |= b[k] < 0.0f;
    }
    const int16 culled = ~(aPos & aNeg & bPos & bNeg);
    if (all(culled)) return (int16)(0);
    const float16 eps = spread / wMin * RC_PATCH_EPS;
    float16 c[16];
    for (int k = 0; k < 16; ++k) {
        const float4 p = pts[k];
        const float16 rx = p.x - L->ox * p.w, ry = p.y - L->oy * p.w, rz = p.z - L->oz * p.w;
        c[k] = Dx * rx + Dy * ry + Dz * rz;
    }
    /* rc_patch_box_newton's searches: the restarts for the lanes whose centre search did not
     * converge. */
    int16 hit = 0, centreConverged = 0;
    float16 tHit = 0.0f, uHit = 0.0f, vHit = 0.0f, nearest = tmax;
    for (int start = 0; start < RC_PATCH_STARTS; ++start) {
        int16 todo = ~culled & ~centreConverged;
        if (!any(todo)) break;
        const float s0 = RC_PATCH_START_S(start), t0 = RC_PATCH_START_T(start);
        if (start > 0) {
            todo &= rc_patch_quarter_straddles16(a, s0 > 0.5f, t0 > 0.5f) &
                    rc_patch_quarter_straddles16(b, s0 > 0.5f, t0 > 0.5f);
            if (!any(todo)) continue;
        }
        float16 s = s0, t = t0;
        const int16 found = rc_packet_patch_search(a, b, w, eps, todo, &s, &t) & todo;
        if (start == 0) centreConverged = found;
        const int16 inU =
            (s >= 0.0f) & ((s < 1.0f) | ((box->closedU ? (int16)(-1) : (int16)(0)) & (s == 1.0f)));
        const int16 inV =
            (t >= 0.0f) & ((t < 1.0f) | ((box->closedV ? (int16)(-1) : (int16)(0)) & (t == 1.0f)));
        int16 now = found & inU & inV;
        if (!any(now)) continue;
        float16 bu[4], dbu[4], bv[4], dbv[4];
        rc_bernstein3_16(s, bu, dbu);
        rc_bernstein3_16(t, bv, dbv);
        float16 C, Cs, Ct, W, Ws, Wt;
        rc_patch_channel16(c, bu, dbu, bv, dbv, &C, &Cs, &Ct);
        rc_patch_weights16(w, bu, dbu, bv, dbv, &W, &Ws, &Wt);
        const float16 th = C / W;
        now &= (th > L->tmin) & (th < nearest);
        nearest = select(nearest, th, now);
        tHit = select(tHit, th, now);
        uHit = select(uHit, s, now);
        vHit = select(vHit, t, now);
        hit |= now;
    }
    *tOut = tHit;
    *uOut = uHit;
    *vOut = vHit;
    return hit;
}
