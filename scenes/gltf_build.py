"""What the scene generators share: small vector helpers, a camera's rotation, and a glTF buffer that
grows accessor by accessor (standard library only)."""

import base64, math, struct


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def normalize(a):
    n = math.sqrt(dot(a, a))
    return tuple(x / n for x in a)


def look_at_quaternion(forward, up):
    """The rotation that turns the camera's −Z along `forward` with `up` up, as glTF's (x, y, z, w)."""
    f = normalize(forward)
    r = normalize(cross(f, up))
    u = cross(r, f)
    b = tuple(-c for c in f)
    m = [[r[0], u[0], b[0]], [r[1], u[1], b[1]], [r[2], u[2], b[2]]]
    w = math.sqrt(max(0.0, 1 + m[0][0] + m[1][1] + m[2][2])) / 2
    return [(m[2][1] - m[1][2]) / (4 * w), (m[0][2] - m[2][0]) / (4 * w), (m[1][0] - m[0][1]) / (4 * w), w]


class Buffer:
    """One embedded buffer, its views and accessors."""

    def __init__(self):
        self.accessors, self.views, self.data = [], [], bytearray()

    def add(self, values, fmt, kind, component, **extra):
        chunk = b"".join(struct.pack(fmt, *v) if isinstance(v, tuple) else struct.pack(fmt, v) for v in values)
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(chunk)})
        self.data.extend(chunk)
        while len(self.data) % 4:
            self.data.append(0)
        self.accessors.append({"bufferView": len(self.views) - 1, "componentType": component,
                               "count": len(values), "type": kind, **extra})
        return len(self.accessors) - 1

    def mesh(self, name, positions, normals, indices, material):
        """A one-primitive triangle mesh; positions get the min/max glTF requires."""
        lo = [min(p[i] for p in positions) for i in range(3)]
        hi = [max(p[i] for p in positions) for i in range(3)]
        p = self.add(positions, "<3f", "VEC3", 5126, min=lo, max=hi)
        n = self.add(normals, "<3f", "VEC3", 5126)
        i = self.add(indices, "<I", "SCALAR", 5125)
        return {"name": name, "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i,
                                              "material": material, "mode": 4}]}

    def gltf_fields(self):
        return {"accessors": self.accessors, "bufferViews": self.views,
                "buffers": [{"byteLength": len(self.data), "uri": "data:application/octet-stream;base64,"
                             + base64.b64encode(bytes(self.data)).decode()}]}
