/* The native recorder's one function (harness/engine/native.py builds and loads it).

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
int mjh_abi(void) { return 3; }

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
   Returns -1 when every sample is recorded, else the sample at whose checks MuJoCo raised a warning
   (nothing of it is recorded), or -2 when nstate is not this model's state size. */
int mjh_record(const mjModel* m, mjData* d, int steps, int integrator, double* states, int nstate,
               int nfield, void* const* src, const long* size, void* const* dst,
               int nrows, double* force, double* pos, int* rows_ok) {
  const int sig = mjSTATE_INTEGRATION;
  if (mj_stateSize(m, sig) != nstate) {
    return -2;
  }
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
    for (int w = 0; w < mjNWARNING; w++) {
      if (d->warning[w].number > 0) {
        return k;
      }
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
    if (k == steps) {
      break;
    }
    if (integrator == 2) {
      mj_RungeKutta(m, d, 4);
    }
    mj_getState(m, d, states + (size_t)(k + 1) * nstate, sig);
  }
  return -1;
}
