"""Helpers of the robustness rostests: the node's pid and memory, raw (malformed) publishing."""
import os
import struct
import sys
import xmlrpc.client

import genpy
import rosgraph
import rosnode

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'ros'))


def node_pid(name='/collision_monitor'):
    """The pid of a ROS node (through its XML-RPC API), or None."""
    try:
        uri = rosnode.get_api_uri(rosgraph.Master('/robust_util'), name, skip_cache=True)
        if not uri:
            return None
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid('/robust_util')
        return pid if code == 1 else None
    except (OSError, rosnode.ROSNodeIOException, xmlrpc.client.Error):
        return None


def proc_status_kb(pid, key):
    """VmRSS / VmHWM / Threads ... of a process from /proc/<pid>/status (kB for memory)."""
    try:
        with open('/proc/%d/status' % pid) as f:
            for line in f:
                if line.startswith(key + ':'):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def alive(pid):
    return pid is not None and os.path.exists('/proc/%d' % pid)


def raw_class(msg_class):
    """A message class with the type and md5 of `msg_class` whose instances carry their serialized
    bytes directly (wrong lengths, truncated arrays, 10-million-vertex bodies): RawX(payload)."""
    def __init__(self, payload=b''):
        self.payload = payload

    def serialize(self, buff):
        buff.write(self.payload)

    return type('Raw' + msg_class.__name__, (genpy.Message,), {
        '_type': msg_class._type, '_md5sum': msg_class._md5sum,
        '_full_text': msg_class._full_text, '_has_header': False, '__slots__': ['payload'],
        '_slot_types': ['raw'], '__init__': __init__, 'serialize': serialize})


def _u32(n):
    return struct.pack('<I', n)


def _str(s, claimed=None):
    b = s if isinstance(s, bytes) else s.encode()
    return _u32(len(b) if claimed is None else claimed) + b


def shape_bytes(kind, dims=(), n_vertices=0, vertex_bytes=None, resource=b'', claimed_dims=None):
    """Serialized collision_monitor/Shape (identity pose, zero scale). `n_vertices` zero points
    unless vertex_bytes is given; claimed_dims overrides the dimensions array length prefix."""
    out = struct.pack('<B', kind)
    out += _u32(len(dims) if claimed_dims is None else claimed_dims)
    out += b''.join(struct.pack('<d', d) for d in dims)
    out += _u32(n_vertices)
    out += vertex_bytes if vertex_bytes is not None else bytes(24 * n_vertices)
    out += _str(resource)
    out += struct.pack('<3d', 0, 0, 0)  # scale
    out += struct.pack('<7d', 0, 0, 0, 0, 0, 0, 1)  # pose
    return out


def body_bytes(body_id, frame, parts, claimed_parts=None, padding=0.0, pose_from_topic=False,
               operation=0, id_claimed=None):
    """Serialized collision_monitor/Body from serialized parts."""
    out = _u32(0) + _u32(0) + _u32(0) + _str(frame)  # header
    out += _str(body_id, id_claimed) + struct.pack('<B', operation) + _str('')
    out += _u32(len(parts) if claimed_parts is None else claimed_parts) + b''.join(parts)
    out += struct.pack('<d?', padding, pose_from_topic) + _str('')
    return out


def save_figures(file_name, lines):
    """Writes a test's figures, one per line, to $CM_ARTIFACTS/<file_name> if that is set."""
    out = os.environ.get('CM_ARTIFACTS')
    if out:
        os.makedirs(out, exist_ok=True)
        with open(os.path.join(out, file_name), 'w') as f:
            f.write('\n'.join(lines) + '\n')
