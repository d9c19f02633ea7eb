"""A Pinocchio model of a chain mechanism (tests only): the legs as a kinematic
tree from the joints (one Pinocchio joint per joint variable, placed at its
point at the reference configuration, where every frame is the world's), the
platform on a free flyer, the loops closed in the inverse dynamics by the
frames' Jacobians: RNEA on the open tree, the passive rows balanced by the
loop forces, the actuated rows giving the actuator forces (as the MuJoCo
check does, with another library's kinematics and dynamics)."""
from __future__ import annotations

import numpy as np

from optdesign.mechanisms.described.chain_constants import PARA, SLIDE
from optdesign.mechanisms.described.chain_dynamics import chain_dynamics
from optdesign.mechanisms.described.chain_solve import full_rate_map
from optdesign.mechanisms.described.poses import rate_bias


class PinChains:
    def __init__(self, mech):
        import pinocchio as pin

        self.pin, self.mech = pin, mech
        cc = mech.chain_constants
        C = cc.base
        assert mech.pose_spec.type == "spatial" and not mech.description.legs
        m = self.model = pin.Model()
        m.gravity.linear = np.array([0.0, 0.0, -float(C.g)])
        fid = m.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform")
        m.appendBodyToJoint(fid, pin.Inertia(float(C.m_platform), np.asarray(C.com, float), np.asarray(C.I_platform, float)),
                            pin.SE3.Identity())
        self.frames = []
        self.vars = []           # per leg: per variable (v index, second v index or None)
        for i, leg in enumerate(cc.legs):
            parent, origin = 0, np.zeros(3)
            ids = []
            masses = {v: (mm, c, I) for v, mm, c, I in leg.bodies}
            for j, code in enumerate(leg.codes):
                a, c = np.asarray(leg.axis[j], float), np.asarray(leg.point[j], float)
                jm = pin.JointModelPrismaticUnaligned(a) if code == SLIDE else pin.JointModelRevoluteUnaligned(a)
                jid = m.addJoint(parent, jm, pin.SE3(np.eye(3), c - origin), f"c{i}_{j}")
                parent, origin = jid, c
                second = None
                if code == PARA:
                    c2 = c + np.asarray(leg.side[j], float)
                    jid = m.addJoint(parent, pin.JointModelRevoluteUnaligned(a), pin.SE3(np.eye(3), c2 - origin),
                                     f"c{i}_{j}b")
                    parent, origin, second = jid, c2, jid
                if j in masses:
                    mm, cen, I = masses[j]
                    m.appendBodyToJoint(parent, pin.Inertia(float(mm), np.asarray(cen, float) - origin, np.asarray(I, float)),
                                        pin.SE3.Identity())
                ids.append((jid if second is None else jid - 1, second))
            self.vars.append(ids)
            fe = m.addFrame(pin.Frame(f"end{i}", parent, pin.SE3(np.eye(3), np.asarray(leg.end, float) - origin),
                                      pin.FrameType.OP_FRAME))
            fp = m.addFrame(pin.Frame(f"plat{i}", fid, pin.SE3(np.eye(3), np.asarray(leg.P, float)), pin.FrameType.OP_FRAME))
            self.frames.append((fe, fp, leg.closure))
        self.data = m.createData()
        self.act = [m.joints[self.vars[i][cc.legs[i].act][0]].idx_v for _, _, i in mech.description.actuators]
        self.passive = np.setdiff1d(np.arange(m.nv), self.act)

    def state(self, X, V, A):
        mech, m = self.mech, self.model
        spec = mech.pose_spec
        X, V, A = (np.asarray(v, float).reshape(1, -1) for v in (X, V, A))
        core = mech.state(X).core
        dyn = chain_dynamics(mech, core, V)
        ub = dyn["ub"][0]
        U = core["U"][0]
        ud, udd = U @ V[0], U @ A[0] + ub
        fr = core["st"]["frames"]
        S = full_rate_map(spec, fr)[0]
        xd = core["P"][0] @ V[0]
        xdd = core["P"][0] @ A[0] + dyn["xf_bias"][0]
        xi, xid = S @ xd, S @ xdd + rate_bias(spec, fr, xd[None])[0]
        R, o = fr.R[0], fr.origin[0]
        q, v, a = np.zeros(m.nq), np.zeros(m.nv), np.zeros(m.nv)
        q[:3] = o
        q[3:7] = self.pin.Quaternion(R).coeffs()
        v[:3], v[3:6] = R.T @ xi[:3], R.T @ xi[3:]
        a[:3], a[3:6] = R.T @ (xid[:3] - np.cross(xi[3:], xi[:3])), R.T @ xid[3:]
        off = 0
        for i, ids in enumerate(self.vars):
            for j, (jid, second) in enumerate(ids):
                jm = m.joints[jid]
                q[jm.idx_q], v[jm.idx_v], a[jm.idx_v] = core["theta"][i][0, j], ud[off + j], udd[off + j]
                if second is not None:
                    js = m.joints[second]
                    q[js.idx_q], v[js.idx_v], a[js.idx_v] = -core["theta"][i][0, j], -ud[off + j], -udd[off + j]
            off += len(ids)
        return q, v, a

    def loop_jacobian(self, q):
        pin, m, d = self.pin, self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        rows, gap = [], 0.0
        for fe, fp, closure in self.frames:
            Je = pin.getFrameJacobian(m, d, fe, pin.LOCAL_WORLD_ALIGNED)
            Jp = pin.getFrameJacobian(m, d, fp, pin.LOCAL_WORLD_ALIGNED)
            rows.append((Je - Jp)[:3] if closure == "position" else Je - Jp)
            gap = max(gap, float(np.linalg.norm(d.oMf[fe].translation - d.oMf[fp].translation)))
        for ids in self.vars:
            for jid, second in ids:
                if second is not None:
                    r = np.zeros((1, m.nv))
                    r[0, m.joints[jid].idx_v] = r[0, m.joints[second].idx_v] = 1.0
                    rows.append(r)
        return np.vstack(rows), gap

    def inverse_dynamics(self, X, V, A):
        """Actuator forces (N, n_act) and the largest loop gap (m)."""
        pin = self.pin
        out, gap = [], 0.0
        for x, vv, aa in zip(np.atleast_2d(X), np.atleast_2d(V), np.atleast_2d(A)):
            q, v, a = self.state(x, vv, aa)
            tau = pin.rnea(self.model, self.data, q, v, a)
            Jc, g = self.loop_jacobian(q)
            gap = max(gap, g)
            lam, *_ = np.linalg.lstsq(Jc[:, self.passive].T, tau[self.passive], rcond=None)
            out.append(tau[self.act] - Jc[:, self.act].T @ lam)
        return np.array(out), gap

    def mass_matrix(self, X):
        """Phi^T M(q) Phi (n, n): Pinocchio's CRBA reduced to the independent rates."""
        pin = self.pin
        n = len(np.ravel(X))
        z = np.zeros(n)
        q = self.state(X, z, z)[0]
        Phi = np.stack([self.state(X, e, z)[1] for e in np.eye(n)], 1)
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        return Phi.T @ M @ Phi
