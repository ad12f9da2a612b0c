/* A chain's tip pose and the shared check's errors by Pinocchio's own C++ forward kinematics, in one call
 * (the Python module wbik.kernels._chain_fk; its Python twin: wbik.robot.Chain's Pinocchio-binding path):
 *
 * - build: a copy of a chain's reduced model (its 1-DOF joints, as Pinocchio's joint types RX, RY, RZ,
 *   RevoluteUnaligned, PX, PY, PZ, PrismaticUnaligned, their parents and placements; the tip frame) held
 *   in a capsule with its Data;
 * - tip_pose: forwardKinematics + updateFramePlacement of the tip, as the binding's calls compute it;
 * - tip_errors: the same pose, then the errors of _checked_errors.h (the shared check's rule).
 *
 * Header-only Pinocchio (no library linked): the same templates the binding runs, built without fused
 * multiply-add, so both give the same bits (tests/test_chain_fk.py compares them on the seed and zoo
 * chains). The Data is shared by every caller: each call runs under the GIL, start to end.
 */
#include "_buffers.h"
#include "_pose_errors.h"
#include "_checked_errors.h"

#include <memory>
#include <vector>
#include <string>

#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>

/* The joint types the copy holds, as Pinocchio's default collection defines them: a variant of 8 types
 * (and the mimic joint Model's code names) instead of that collection's 24: the same joint code, less to
 * compile. */
template<typename _Scalar, int _Options>
struct ChainJointCollectionTpl
{
    typedef _Scalar Scalar;
    enum { Options = _Options };
    typedef boost::variant<pinocchio::JointModelRevoluteTpl<Scalar, Options, 0>,
                           pinocchio::JointModelRevoluteTpl<Scalar, Options, 1>,
                           pinocchio::JointModelRevoluteTpl<Scalar, Options, 2>,
                           pinocchio::JointModelRevoluteUnalignedTpl<Scalar, Options>,
                           pinocchio::JointModelPrismaticTpl<Scalar, Options, 0>,
                           pinocchio::JointModelPrismaticTpl<Scalar, Options, 1>,
                           pinocchio::JointModelPrismaticTpl<Scalar, Options, 2>,
                           pinocchio::JointModelPrismaticUnalignedTpl<Scalar, Options>,
                           boost::recursive_wrapper<pinocchio::JointModelMimicTpl<Scalar, Options,
                                                                                  ChainJointCollectionTpl>>>
        JointModelVariant;
    typedef boost::variant<pinocchio::JointDataRevoluteTpl<Scalar, Options, 0>,
                           pinocchio::JointDataRevoluteTpl<Scalar, Options, 1>,
                           pinocchio::JointDataRevoluteTpl<Scalar, Options, 2>,
                           pinocchio::JointDataRevoluteUnalignedTpl<Scalar, Options>,
                           pinocchio::JointDataPrismaticTpl<Scalar, Options, 0>,
                           pinocchio::JointDataPrismaticTpl<Scalar, Options, 1>,
                           pinocchio::JointDataPrismaticTpl<Scalar, Options, 2>,
                           pinocchio::JointDataPrismaticUnalignedTpl<Scalar, Options>,
                           boost::recursive_wrapper<pinocchio::JointDataMimicTpl<Scalar, Options,
                                                                                 ChainJointCollectionTpl>>>
        JointDataVariant;
};

namespace {

typedef pinocchio::ModelTpl<double, 0, ChainJointCollectionTpl> Model;
typedef pinocchio::DataTpl<double, 0, ChainJointCollectionTpl> Data;
const char *const CAPSULE = "wbik.kernels._chain_fk.Chain";
enum JointKind { RX, RY, RZ, REVOLUTE_UNALIGNED, PX, PY, PZ, PRISMATIC_UNALIGNED, KINDS };

struct ChainModel {
    Model model;
    std::unique_ptr<Data> data;
    pinocchio::FrameIndex tip = 0;
    Eigen::VectorXd q;
};

void drop(PyObject *capsule)
{
    delete static_cast<ChainModel *>(PyCapsule_GetPointer(capsule, CAPSULE));
}

pinocchio::SE3 placement_of(const double m[16])
{
    Eigen::Matrix3d rotation;
    rotation << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
    return pinocchio::SE3(rotation, Eigen::Vector3d(m[3], m[7], m[11]));
}

/* A (n,) sequence of ints as a vector; -1 and a TypeError naming it otherwise. */
int read_ints(PyObject *object, std::vector<long> &out, const char *what)
{
    PyObject *sequence = PySequence_Fast(object, what);
    if (sequence == NULL)
        return -1;
    const Py_ssize_t count = PySequence_Fast_GET_SIZE(sequence);
    out.resize(count);
    for (Py_ssize_t i = 0; i < count; i++) {
        out[i] = PyLong_AsLong(PySequence_Fast_GET_ITEM(sequence, i));
        if (out[i] == -1 && PyErr_Occurred()) {
            Py_DECREF(sequence);
            PyErr_Format(PyExc_TypeError, "%s: expected ints", what);
            return -1;
        }
    }
    Py_DECREF(sequence);
    return 0;
}

void add_joint(Model &model, long kind, long parent, const Eigen::Vector3d &axis,
               const pinocchio::SE3 &placement, const std::string &name)
{
    const auto index = static_cast<pinocchio::JointIndex>(parent);
    switch (kind) {
    case RX: model.addJoint(index, pinocchio::JointModelRX(), placement, name); break;
    case RY: model.addJoint(index, pinocchio::JointModelRY(), placement, name); break;
    case RZ: model.addJoint(index, pinocchio::JointModelRZ(), placement, name); break;
    case REVOLUTE_UNALIGNED:
        model.addJoint(index, pinocchio::JointModelRevoluteUnaligned(axis), placement, name);
        break;
    case PX: model.addJoint(index, pinocchio::JointModelPX(), placement, name); break;
    case PY: model.addJoint(index, pinocchio::JointModelPY(), placement, name); break;
    case PZ: model.addJoint(index, pinocchio::JointModelPZ(), placement, name); break;
    default: model.addJoint(index, pinocchio::JointModelPrismaticUnaligned(axis), placement, name); break;
    }
}

/* build(kinds, parents, axes, placements, tip_joint, tip_placement) -> capsule
 * kinds (n,): JointKind per joint 1..n of the model; parents (n,): each joint's parent (0: the root, else an
 * earlier joint); axes (n, 3): an unaligned joint's axis (ignored for the others); placements (n, 16): each
 * joint's placement in its parent, a 4x4 row by row; the tip frame: its joint and its 4x4 placement there. */
PyObject *build(PyObject *, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("build", nargs, 6) < 0)
        return NULL;
    std::vector<long> kinds, parents;
    if (read_ints(args[0], kinds, "kinds") < 0 || read_ints(args[1], parents, "parents") < 0)
        return NULL;
    const Py_ssize_t joints = static_cast<Py_ssize_t>(kinds.size());
    if (static_cast<Py_ssize_t>(parents.size()) != joints) {
        PyErr_SetString(PyExc_ValueError, "build: kinds and parents differ in length");
        return NULL;
    }
    std::vector<double> axes(3 * joints + 1), placements(16 * joints + 1);
    double tip_placement[16];
    long tip_joint = PyLong_AsLong(args[4]);
    if ((tip_joint == -1 && PyErr_Occurred()) || read_doubles(args[2], axes.data(), joints, 3, "axes") < 0
        || read_doubles(args[3], placements.data(), joints, 16, "placements") < 0
        || read_doubles(args[5], tip_placement, 4, 4, "tip_placement") < 0)
        return NULL;
    if (tip_joint < 0 || tip_joint > joints) {
        PyErr_Format(PyExc_ValueError, "build: tip joint %ld is not one of the %zd joints", tip_joint, joints);
        return NULL;
    }
    auto chain = std::make_unique<ChainModel>();
    try {
        for (Py_ssize_t i = 0; i < joints; i++) {
            if (kinds[i] < 0 || kinds[i] >= KINDS || parents[i] < 0 || parents[i] > i) {
                PyErr_Format(PyExc_ValueError, "build: joint %zd has kind %ld and parent %ld", i + 1, kinds[i],
                             parents[i]);
                return NULL;
            }
            const double *axis = &axes[3 * i];
            add_joint(chain->model, kinds[i], parents[i], Eigen::Vector3d(axis[0], axis[1], axis[2]),
                      placement_of(&placements[16 * i]), "joint_" + std::to_string(i + 1));
        }
        chain->tip = chain->model.addFrame(pinocchio::Frame("tip", static_cast<pinocchio::JointIndex>(tip_joint),
                                                            placement_of(tip_placement), pinocchio::OP_FRAME));
        chain->data = std::make_unique<Data>(chain->model);
        chain->q = Eigen::VectorXd::Zero(chain->model.nq);
    } catch (const std::exception &error) {
        PyErr_Format(PyExc_ValueError, "build: %s", error.what());
        return NULL;
    }
    PyObject *capsule = PyCapsule_New(chain.get(), CAPSULE, drop);
    if (capsule != NULL)
        chain.release();
    return capsule;
}

/* The capsule's chain with q read and its tip placed (reached, row by row); NULL with an error otherwise. */
ChainModel *placed(PyObject *capsule, PyObject *q, double reached[16])
{
    auto *chain = static_cast<ChainModel *>(PyCapsule_GetPointer(capsule, CAPSULE));
    if (chain == NULL || read_doubles(q, chain->q.data(), chain->model.nq, 0, "q") < 0)
        return NULL;
    pinocchio::forwardKinematics(chain->model, *chain->data, chain->q);
    const pinocchio::SE3 &tip = pinocchio::updateFramePlacement(chain->model, *chain->data, chain->tip);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            reached[4 * i + j] = tip.rotation()(i, j);
        reached[4 * i + 3] = tip.translation()(i);
    }
    reached[12] = reached[13] = reached[14] = 0.0;
    reached[15] = 1.0;
    return chain;
}

/* tip_pose(chain, q, out): the tip frame's 4x4 pose in the model's root frame into out (4, 4). */
PyObject *tip_pose(PyObject *, PyObject *const *args, Py_ssize_t nargs)
{
    double reached[16];
    if (check_count("tip_pose", nargs, 3) < 0 || placed(args[0], args[1], reached) == NULL
        || write_doubles(args[2], reached, 16, "out") < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* tip_errors(chain, q, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|,
 * exact): the errors of the tip pose of q, as wbik.kernels._pose.pose_errors gives them for that pose. */
PyObject *tip_errors(PyObject *, PyObject *const *args, Py_ssize_t nargs)
{
    double reached[16];
    if (check_count("tip_errors", nargs, 7) < 0 || placed(args[0], args[1], reached) == NULL)
        return NULL;
    return checked_errors_tuple(reached, args[2], args[3], args[4], args[5], args[6]);
}

PyMethodDef methods[] = {
    {"build", (PyCFunction)(void (*)(void))build, METH_FASTCALL,
     "build(kinds, parents, axes, placements, tip_joint, tip_placement) -> a chain's model for tip_pose"},
    {"tip_pose", (PyCFunction)(void (*)(void))tip_pose, METH_FASTCALL,
     "tip_pose(chain, q, out): the tip's 4x4 pose in the root frame, by Pinocchio's FK"},
    {"tip_errors", (PyCFunction)(void (*)(void))tip_errors, METH_FASTCALL,
     "tip_errors(chain, q, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, "
     "|e_R|, exact): the shared check's errors of the tip pose of q"},
    {NULL, NULL, 0, NULL}};

struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_chain_fk",
                             "A chain's tip pose and errors by Pinocchio's C++ FK (wbik.kernels).", -1, methods,
                             NULL, NULL, NULL, NULL};

}  // namespace

PyMODINIT_FUNC PyInit__chain_fk(void)
{
    return PyModule_Create(&module);
}
