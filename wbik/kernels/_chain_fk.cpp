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
#include <structmember.h>

#include <cmath>
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
    Eigen::VectorXd q, lower, upper;
    bool moved_base = false;
    double base_inverse[16];
};

PyObject *ndarray_type;  /* numpy.ndarray and numpy.empty, read when the module is imported */
PyObject *empty_array;
PyObject *copy_name;

/* The answer type (wbik.solvers.result.IKResult, registered by result_type): its slots' offsets in field
 * order. */
const int RESULT_FIELDS = 17;
PyTypeObject *result_type_object = NULL;
Py_ssize_t result_offsets[RESULT_FIELDS];

void drop(PyObject *capsule)
{
    delete static_cast<ChainModel *>(PyCapsule_GetPointer(capsule, CAPSULE));
}

/* The chain a capsule made by build holds; NULL and a TypeError for anything else. */
ChainModel *chain_of(PyObject *capsule)
{
    if (PyCapsule_IsValid(capsule, CAPSULE))
        return static_cast<ChainModel *>(PyCapsule_GetPointer(capsule, CAPSULE));
    PyErr_Format(PyExc_TypeError, "expected a chain made by build, got %s", Py_TYPE(capsule)->tp_name);
    return NULL;
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

/* build(kinds, parents, axes, placements, tip_joint, tip_placement, lower, upper, base_inverse) -> capsule
 * kinds (n,): JointKind per joint 1..n of the model; parents (n,): each joint's parent (0: the root, else an
 * earlier joint); axes (n, 3): an unaligned joint's axis (ignored for the others); placements (n, 16): each
 * joint's placement in its parent, a 4x4 row by row; the tip frame: its joint and its 4x4 placement there;
 * the joints' limits (n,) each; the chain's base frame: None (the root) or the 4x4 inverse of its placement. */
PyObject *build_body(PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("build", nargs, 9) < 0)
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
    chain->lower.resize(joints);
    chain->upper.resize(joints);
    chain->moved_base = args[8] != Py_None;
    if (read_doubles(args[6], chain->lower.data(), joints, 0, "lower") < 0
        || read_doubles(args[7], chain->upper.data(), joints, 0, "upper") < 0
        || (chain->moved_base && read_doubles(args[8], chain->base_inverse, 4, 4, "base_inverse") < 0))
        return NULL;
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

/* The tip's pose at chain.q (4x4, row by row), by Pinocchio's forwardKinematics and updateFramePlacement. */
void placed_tip(ChainModel &chain, double reached[16])
{
    pinocchio::forwardKinematics(chain.model, *chain.data, chain.q);
    const pinocchio::SE3 &tip = pinocchio::updateFramePlacement(chain.model, *chain.data, chain.tip);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            reached[4 * i + j] = tip.rotation()(i, j);
        reached[4 * i + 3] = tip.translation()(i);
    }
    reached[12] = reached[13] = reached[14] = 0.0;
    reached[15] = 1.0;
}

/* The capsule's chain with q read and its tip placed (reached, row by row); NULL with an error otherwise. */
ChainModel *placed(PyObject *capsule, PyObject *q, double reached[16])
{
    ChainModel *chain = chain_of(capsule);
    if (chain == NULL || read_doubles(q, chain->q.data(), chain->model.nq, 0, "q") < 0)
        return NULL;
    placed_tip(*chain, reached);
    return chain;
}

/* The capsule's chain and q as a plain float64 (n,) numpy array of finite joints within the copied limits,
 * read into chain->q (inside_limits' test); NULL (no error set) for anything else but a bad capsule. */
ChainModel *inside(PyObject *capsule, PyObject *q)
{
    ChainModel *chain = chain_of(capsule);
    if (chain == NULL || (PyObject *)Py_TYPE(q) != ndarray_type)
        return NULL;
    Py_buffer view;
    if (float64_view(q, &view, 0, "") < 0) {
        PyErr_Clear();
        return NULL;
    }
    const Py_ssize_t n = chain->model.nq;
    bool plain = view.ndim == 1 && view.shape[0] == n;
    for (Py_ssize_t i = 0; plain && i < n; i++) {
        const double value = *(const double *)((const char *)view.buf + i * view.strides[0]);
        plain = std::isfinite(value) && chain->lower[i] <= value && value <= chain->upper[i];
        chain->q[i] = value;
    }
    PyBuffer_Release(&view);
    return plain ? chain : NULL;
}

/* tip_pose(chain, q, out): the tip frame's 4x4 pose in the model's root frame into out (4, 4). */
PyObject *tip_pose_body(PyObject *const *args, Py_ssize_t nargs)
{
    double reached[16];
    if (check_count("tip_pose", nargs, 3) < 0 || placed(args[0], args[1], reached) == NULL
        || write_doubles(args[2], reached, 16, "out") < 0)
        return NULL;
    Py_RETURN_NONE;
}

/* tip_errors(chain, q, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|,
 * exact): the errors of the tip pose of q, as wbik.kernels._pose.pose_errors gives them for that pose. */
PyObject *tip_errors_body(PyObject *const *args, Py_ssize_t nargs)
{
    double reached[16];
    if (check_count("tip_errors", nargs, 7) < 0 || placed(args[0], args[1], reached) == NULL)
        return NULL;
    return checked_errors_tuple(reached, args[2], args[3], args[4], args[5], args[6]);
}

/* result_type(cls, fields): registers the answer type, a class whose fields (17 names, in order) are all
 * object slots (a dataclass with slots=True): checked_result fills them. */
PyObject *result_type_body(PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("result_type", nargs, 2) < 0)
        return NULL;
    if (!PyType_Check(args[0]) || PySequence_Size(args[1]) != RESULT_FIELDS) {
        PyErr_Format(PyExc_TypeError, "result_type: expected a class and %d field names", RESULT_FIELDS);
        return NULL;
    }
    Py_ssize_t offsets[RESULT_FIELDS];  /* kept only when every field is an object slot */
    for (int i = 0; i < RESULT_FIELDS; i++) {
        PyObject *name = PySequence_GetItem(args[1], i);
        PyObject *slot = name == NULL ? NULL : PyObject_GetAttr(args[0], name);
        Py_XDECREF(name);
        if (slot == NULL)
            return NULL;
        const bool member = Py_IS_TYPE(slot, &PyMemberDescr_Type)
                            && ((PyMemberDescrObject *)slot)->d_member->type == T_OBJECT_EX;
        if (member)
            offsets[i] = ((PyMemberDescrObject *)slot)->d_member->offset;
        Py_DECREF(slot);
        if (!member) {
            PyErr_Format(PyExc_TypeError, "result_type: field %d is not an object slot", i);
            return NULL;
        }
    }
    memcpy(result_offsets, offsets, sizeof(offsets));
    Py_XSETREF(result_type_object, (PyTypeObject *)Py_NewRef(args[0]));
    Py_RETURN_NONE;
}

/* A new (3,) float64 array holding values; NULL with an error otherwise. */
PyObject *vector3(const double values[3])
{
    static PyObject *three = PyLong_FromLong(3);
    PyObject *array = PyObject_Vectorcall(empty_array, &three, 1, NULL);
    if (array != NULL && write_doubles(array, values, 3, "errors") < 0)
        Py_CLEAR(array);
    return array;
}

/* checked_result(chain, q, position, rotation, position_tolerance, rotation_tolerance, time_s, iterations,
 * method, extra) -> the answer or None
 * The shared check of joints q, whole, for the common case: q a float64 (n,) numpy array of finite joints
 * within the limits whose tip pose passes the tolerances with the formula keeping the axis. Then the
 * registered answer type, filled as wbik.solvers.check.judged fills it: a copy of q, success, no reason,
 * both norms and error vectors, the time, iterations, method and extra given, empty whole-body fields. None
 * for every other case (the Python check decides those). */
PyObject *checked_result_body(PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("checked_result", nargs, 10) < 0)
        return NULL;
    if (result_type_object == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "checked_result: no answer type registered (result_type)");
        return NULL;
    }
    ChainModel *chain = inside(args[0], args[1]);
    if (chain == NULL) {
        if (PyErr_Occurred())
            return NULL;
        Py_RETURN_NONE;
    }
    double position[3], rotation[9], reached[16], errors[8], position_tolerance, rotation_tolerance;
    const bool pose = args[3] != Py_None;
    if (read_doubles(args[2], position, 3, 0, "position") < 0
        || (pose && read_doubles(args[3], rotation, 3, 3, "rotation") < 0)
        || read_float(args[4], &position_tolerance, "position_tolerance") < 0
        || read_float(args[5], &rotation_tolerance, "rotation_tolerance") < 0)
        return NULL;
    placed_tip(*chain, reached);
    if (chain->moved_base)
        base_moved(reached, chain->base_inverse);
    if (!target_errors(reached, position, pose ? rotation : NULL, errors)
        || !(errors[6] <= position_tolerance && errors[7] <= rotation_tolerance))
        Py_RETURN_NONE;
    PyObject *values[RESULT_FIELDS] = {
        PyObject_CallMethodNoArgs(args[1], copy_name), Py_NewRef(Py_True), PyUnicode_New(0, 0),
        PyFloat_FromDouble(errors[6]), PyFloat_FromDouble(errors[7]), vector3(errors), vector3(errors + 3),
        Py_NewRef(args[6]), Py_NewRef(args[7]), Py_NewRef(args[8]), Py_NewRef(args[9]), PyDict_New(),
        PyDict_New(), PyDict_New(), PyDict_New(), PyList_New(0), Py_NewRef(Py_None)};
    PyObject *result = result_type_object->tp_alloc(result_type_object, 0);
    bool complete = result != NULL;
    for (int i = 0; i < RESULT_FIELDS; i++)
        complete = complete && values[i] != NULL;
    if (!complete) {
        for (int i = 0; i < RESULT_FIELDS; i++)
            Py_XDECREF(values[i]);
        Py_XDECREF(result);
        return NULL;
    }
    for (int i = 0; i < RESULT_FIELDS; i++)
        *(PyObject **)((char *)result + result_offsets[i]) = values[i];  /* the references move in */
    return result;
}

/* An entry point: the body, with a C++ exception (memory, Pinocchio's checks) turned into a Python error
 * instead of crossing the C API. */
template<PyObject *(*body)(PyObject *const *, Py_ssize_t)>
PyObject *guarded(PyObject *, PyObject *const *args, Py_ssize_t nargs)
{
    try {
        return body(args, nargs);
    } catch (const std::bad_alloc &) {
        return PyErr_NoMemory();
    } catch (const std::exception &error) {
        PyErr_Format(PyExc_RuntimeError, "wbik.kernels._chain_fk: %s", error.what());
    } catch (...) {
        PyErr_SetString(PyExc_RuntimeError, "wbik.kernels._chain_fk: an unknown C++ exception");
    }
    return NULL;
}

PyMethodDef methods[] = {
    {"build", (PyCFunction)(void (*)(void))guarded<build_body>, METH_FASTCALL,
     "build(kinds, parents, axes, placements, tip_joint, tip_placement, lower, upper, base_inverse) -> a "
     "chain's model for the other functions"},
    {"result_type", (PyCFunction)(void (*)(void))guarded<result_type_body>, METH_FASTCALL,
     "result_type(cls, fields): the answer type checked_result fills (its 17 slot fields in order)"},
    {"checked_result", (PyCFunction)(void (*)(void))guarded<checked_result_body>, METH_FASTCALL,
     "checked_result(chain, q, position, rotation, position_tolerance, rotation_tolerance, time_s, "
     "iterations, method, extra) -> the checked answer of joints inside the limits that pass, else None"},
    {"tip_pose", (PyCFunction)(void (*)(void))guarded<tip_pose_body>, METH_FASTCALL,
     "tip_pose(chain, q, out): the tip's 4x4 pose in the root frame, by Pinocchio's FK"},
    {"tip_errors", (PyCFunction)(void (*)(void))guarded<tip_errors_body>, METH_FASTCALL,
     "tip_errors(chain, q, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, "
     "|e_R|, exact): the shared check's errors of the tip pose of q"},
    {NULL, NULL, 0, NULL}};

struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_chain_fk",
                             "A chain's tip pose and errors by Pinocchio's C++ FK (wbik.kernels).", -1, methods,
                             NULL, NULL, NULL, NULL};

}  // namespace

PyMODINIT_FUNC PyInit__chain_fk(void)
{
    PyObject *numpy = PyImport_ImportModule("numpy");
    if (numpy == NULL)
        return NULL;
    ndarray_type = PyObject_GetAttrString(numpy, "ndarray"); /* both kept for the module's life */
    empty_array = PyObject_GetAttrString(numpy, "empty");
    Py_DECREF(numpy);
    copy_name = PyUnicode_InternFromString("copy");
    if (ndarray_type == NULL || empty_array == NULL || copy_name == NULL)
        return NULL;
    return PyModule_Create(&module);
}
