/* The native recorder's one function (harness/engine/native.py builds and loads it).

   It makes, in C, exactly the MuJoCo calls the loop recorder makes from Python
   (harness/engine/simulate.py, _record_loop): at every sample k = 0 .. steps,
   mj_forward between the checks mj_step makes around it, a stop at the first
   MuJoCo warning, a copy of what is recorded, then the integrator's own
   function. Recorded: the integration state after every step, the fixed-size
   fields the caller names (by address in this mjData and in its arrays), and
   the first `nrows` rows of efc_force and efc_pos (the equalities' rows, which
   no fixed-size field holds). The same calls in the same order give the same
   numbers as the loop, bit for bit; the caller checks that as for every run. */
#include <string.h>

#include <mujoco/mujoco.h>

/* bumped when a signature below changes: the loader refuses a library of another */
int mjh_abi(void) { return 2; }

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

/* integrator: 0 mj_Euler (Euler, discrete), 1 mj_implicit (implicit, implicitfast), 2 mj_RungeKutta(4).
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
    mj_checkPos(m, d);
    mj_checkVel(m, d);
    mj_forward(m, d);
    mj_checkAcc(m, d);
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
    } else if (integrator == 1) {
      mj_implicit(m, d);
    } else {
      mj_Euler(m, d);
    }
    mj_getState(m, d, states + (size_t)(k + 1) * nstate, sig);
  }
  return -1;
}
