/* The native recorder's one function (harness/engine/recording/native.py builds and loads it).

   It steps with mj_step itself, as mujoco.batch does, and copies at every sample
   k = 0 .. steps what is recorded: the integration state after every step, the
   fixed-size fields the caller names (by address in this mjData and in its
   arrays), and the first `nrows` rows of efc_force and efc_pos (the equalities'
   rows, which no fixed-size field holds). After mj_step the derived fields
   describe the state before it (the integrators change only the state), so
   sample k's are copied after step k + 1. RK4 leaves its last stage in them: there
   each sample is mj_forward between the checks mj_step makes, the copy, then
   mj_RungeKutta, as the loop recorder does. The last sample, which no step
   follows, gets that checked forward too. A MuJoCo warning stops the run at the
   sample whose checks raised it. The caller checks the fields against a fresh
   mj_forward, as for every run. */
#include <string.h>

#include <mujoco/mujoco.h>

/* bumped when a signature below changes: the loader refuses a library of another */
int mjh_abi(void) { return 7; }

/* The address of an int field of mjData's info header, by its place in this list (the loader's SCALARS);
   NULL for another. A fixed-size array field's address the caller takes from its own view of it. */
const void* mjh_scalar(const mjData* d, int which) {
  switch (which) {
    case 0: return &d->ne;
    case 1: return &d->nf;
    case 2: return &d->nl;
    case 3: return &d->nefc;
    case 4: return &d->ncon;
    case 5: return &d->nisland;
    default: return NULL;
  }
}

/* integrator: 2 for RK4 (forward, copy, mj_RungeKutta), anything else for mj_step.
   states: (steps + 1) rows of nstate (mjSTATE_INTEGRATION); row 0 is the caller's.
   field k's sample s goes to dst[k] + s * size[k] from src[k] (size[k] bytes).
   force, pos: (steps + 1) rows of nrows, written where the sample has exactly nrows equality rows;
   *rows_ok is set to 0 at the first sample that has another number of them.
   velocity: npoint blocks of (steps + 1) rows of 3, each point's world velocity (a site's where point_site[p] >= 0,
   else the centre of mass of body point_body[p]); point_root[p] is that body's root, and its chain's dofs
   are chain[chain_start[p] .. chain_start[p + 1] - 1], increasing. position: the same blocks, each point's
   world position (a copy of site_xpos or xipos).
   momentum: nmom blocks of 3 rows of (steps + 1), each the angular momentum of a subtree about site mom_site[a]:
   its bodies are mom_body[mom_start[a] .. mom_start[a + 1] - 1], in the model's body order.
   Returns -1 when every sample is recorded, else the sample at whose checks MuJoCo raised a warning
   (nothing of it is recorded), or -2 when nstate is not this model's state size. */
int mjh_record(const mjModel* m, mjData* d, int steps, int integrator, double* states, int nstate,
               int nfield, void* const* src, const long* size, void* const* dst,
               int nrows, double* force, double* pos, int* rows_ok,
               int npoint, const int* point_body, const int* point_site, const int* point_root,
               const int* chain_start, const int* chain, double* velocity, double* position,
               int nmom, const int* mom_site, const int* mom_start, const int* mom_body, double* momentum) {
  const int sig = mjSTATE_INTEGRATION;
  if (mj_stateSize(m, sig) != nstate) {
    return -2;
  }
  int stopped = -1;
  *rows_ok = 1;
  for (int k = 0; k <= steps; k++) {
    if (integrator == 2 || k == steps) {
      mj_checkPos(m, d);
      mj_checkVel(m, d);
      mj_forward(m, d);
      mj_checkAcc(m, d);
    } else {
      mj_step(m, d);
    }
    for (int w = 0; w < mjNWARNING && stopped < 0; w++) {
      if (d->warning[w].number > 0) {
        stopped = k;
      }
    }
    if (stopped >= 0) {
      break;
    }
    for (int f = 0; f < nfield; f++) {
      memcpy((char*)dst[f] + (size_t)k * (size_t)size[f], src[f], (size_t)size[f]);
    }
    if (nrows > 0) {
      if (d->ne != nrows) {
        *rows_ok = 0;
      } else {
        memcpy(force + (size_t)k * nrows, d->efc_force, sizeof(mjtNum) * nrows);
        memcpy(pos + (size_t)k * nrows, d->efc_pos, sizeof(mjtNum) * nrows);
      }
    }
    /* each point's velocity J qvel at sample k, with the arithmetic of assemble.point_velocity (bit for bit
       the loop's point_state): J's columns as mj_jac makes them, cdof_lin + cdof_ang x (point - subtree_com of
       the body's root), over the dofs of the body's chain in increasing order, each a product then a sum (no
       fused multiply-add: -ffp-contract=off). The derived fields are sample k's; qvel is row k of the states
       (after mj_step, d holds k + 1's). */
    const double* qvel = states + (size_t)k * nstate + 1 + m->nq;
    for (int p = 0; p < npoint; p++) {
      const mjtNum* at = point_site[p] >= 0 ? d->site_xpos + 3 * point_site[p] : d->xipos + 3 * point_body[p];
      const mjtNum* com = d->subtree_com + 3 * point_root[p];
      const double o0 = at[0] - com[0], o1 = at[1] - com[1], o2 = at[2] - com[2];
      double v0 = 0.0, v1 = 0.0, v2 = 0.0;
      for (int c = chain_start[p]; c < chain_start[p + 1]; c++) {
        const mjtNum* dof = d->cdof + 6 * chain[c];
        const double q = qvel[chain[c]];
        v0 = v0 + (dof[3] + (dof[1] * o2 - dof[2] * o1)) * q;
        v1 = v1 + (dof[4] + (dof[2] * o0 - dof[0] * o2)) * q;
        v2 = v2 + (dof[5] + (dof[0] * o1 - dof[1] * o0)) * q;
      }
      double* out = velocity + ((size_t)p * (steps + 1) + k) * 3;
      out[0] = v0;
      out[1] = v1;
      out[2] = v2;
      double* where = position + ((size_t)p * (steps + 1) + k) * 3;
      where[0] = at[0];
      where[1] = at[1];
      where[2] = at[2];
    }
    /* each subtree's angular momentum about its site at sample k, with the arithmetic of the numpy reading
       (harness/engine/readings/momentum.py, _about): per body, cinert . cvel as mju_mulInertVec (angular and
       linear parts) plus (subtree_com of its root - site) x linear, summed over the bodies from 0, every term
       left to right, a product then a sum (no fused multiply-add: -ffp-contract=off). */
    for (int a = 0; a < nmom; a++) {
      const mjtNum* o = d->site_xpos + 3 * mom_site[a];
      double t0 = 0.0, t1 = 0.0, t2 = 0.0;
      for (int c = mom_start[a]; c < mom_start[a + 1]; c++) {
        const int b = mom_body[c];
        const mjtNum* i = d->cinert + 10 * b;
        const mjtNum* v = d->cvel + 6 * b;
        const mjtNum* com = d->subtree_com + 3 * m->body_rootid[b];
        const double a0 = i[0] * v[0] + i[3] * v[1] + i[4] * v[2] - i[8] * v[4] + i[7] * v[5];
        const double a1 = i[3] * v[0] + i[1] * v[1] + i[5] * v[2] + i[8] * v[3] - i[6] * v[5];
        const double a2 = i[4] * v[0] + i[5] * v[1] + i[2] * v[2] - i[7] * v[3] + i[6] * v[4];
        const double l0 = i[8] * v[1] - i[7] * v[2] + i[9] * v[3];
        const double l1 = i[6] * v[2] - i[8] * v[0] + i[9] * v[4];
        const double l2 = i[7] * v[0] - i[6] * v[1] + i[9] * v[5];
        const double e0 = com[0] - o[0], e1 = com[1] - o[1], e2 = com[2] - o[2];
        t0 = t0 + (a0 + (e1 * l2 - e2 * l1));
        t1 = t1 + (a1 + (e2 * l0 - e0 * l2));
        t2 = t2 + (a2 + (e0 * l1 - e1 * l0));
      }
      double* out = momentum + (size_t)a * 3 * (steps + 1) + k;
      out[0] = t0;
      out[steps + 1] = t1;
      out[2 * (size_t)(steps + 1)] = t2;
    }
    if (k == steps) {
      break;
    }
    if (integrator == 2) {
      mj_RungeKutta(m, d, 4);
    }
    mj_getState(m, d, states + (size_t)(k + 1) * nstate, sig);
  }
  return stopped;
}
