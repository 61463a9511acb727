#!/usr/bin/env python3
"""Writes the seed corpora of fuzz/corpus/ (Python standard library only).

Seeds are small valid inputs plus a few near misses, one per feature worth
reaching: the fuzzer mutates them. Re-run after changing a format; files not
written here (the MJPEG frames of frame_convert, made with OpenCV, see
README.md) are left alone.
"""
import io
import json
import pathlib
import struct
import tarfile
import zlib

HERE = pathlib.Path(__file__).resolve().parent
CORPUS = HERE / "corpus"
TOKEN = "fuzz-token"  # fuzz_daemon.h kFuzzToken


def write(harness, name, data):
    path = CORPUS / harness / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data if isinstance(data, bytes) else data.encode())


def png(width, height, channels, seed):
    """An 8-bit gray (1) or RGB (3) PNG with a deterministic texture."""
    rows = b"".join(
        b"\x00" + bytes((x * 37 + y * 11 + seed * 5 + c * 71) % 256
                        for x in range(width) for c in range(channels))
        for y in range(height))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    color_type = 0 if channels == 1 else 2
    header = struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
            chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def manifest(width=8, height=6, frames=3, pixel_format="gray8", **extra):
    body = {"format": "dfsm-burst/1", "width": width, "height": height,
            "pixel_format": pixel_format, "reference": 0,
            "frames": [{"file": f"frames/{i:06d}.png", "timestamp_ns": i * 33333333,
                        "sequence": i} for i in range(frames)]}
    body.update(extra)
    return json.dumps(body, indent=1)


def burst_tar(top="", channels=1, tar_format=tarfile.USTAR_FORMAT, directories=False):
    """A dfsm-burst/1 directory as the upload route takes it."""
    out = io.BytesIO()
    with tarfile.open(fileobj=out, mode="w", format=tar_format) as tar:
        def add(name, data, kind=tarfile.REGTYPE):
            info = tarfile.TarInfo(top + name)
            info.type, info.mode, info.mtime = kind, 0o644, 1700000000
            info.size = len(data) if kind == tarfile.REGTYPE else 0
            tar.addfile(info, io.BytesIO(data) if kind == tarfile.REGTYPE else None)

        if directories and top:
            add("", b"", tarfile.DIRTYPE)
        if directories:
            add("frames", b"", tarfile.DIRTYPE)
        add("manifest.json",
            manifest(pixel_format="gray8" if channels == 1 else "bgr8").encode())
        for i in range(3):
            add(f"frames/{i:06d}.png", png(8, 6, channels, i))
    return out.getvalue()


def burst_manifest_seeds():
    h = "burst_manifest"
    write(h, "minimal.json", json.dumps(
        {"format": "dfsm-burst/1", "width": 2, "height": 2,
         "frames": [{"file": "a.png"}, {"file": "b.png"}, {"file": "c.png"}]}))
    write(h, "full.json", manifest(1920, 1080, 10, "bgr8", reference=4, source={
        "device": "/dev/video0", "driver": "uvcvideo", "format": "MJPG", "fps": 30.0,
        "sequence": [100, 109]}))
    write(h, "two-frames.json", manifest(frames=2))
    write(h, "bad-reference.json", manifest(reference=7))
    write(h, "wrong-format.json", manifest().replace("dfsm-burst/1", "dfsm-burst/2"))
    write(h, "width-string.json", manifest().replace('"width": 8', '"width": "8"'))
    write(h, "negative-timestamp.json", manifest().replace("33333333", "-1"))
    write(h, "not-json.json", '{"format": "dfsm-burst/1", "width": ')


def config_seeds():
    h = "config"
    write(h, "dfsmd.toml", (HERE.parent / "config" / "dfsmd.toml").read_text())
    write(h, "empty.toml", "")
    write(h, "small.toml", '[server]\nport = 0\nthreads = 2\n[capture]\nsource = "synthetic:"\n'
          'fps = 29.97\n[pipeline]\nframes = 12\nwhen = "next"\ndense = false\n'
          '[retention]\nmax_bytes = 1_000_000\n')
    write(h, "wrong-type.toml", '[server]\nport = "8080"\n')
    write(h, "unknown-key.toml", '[jobs]\nwokers = 2\n')
    write(h, "inline.toml", 'server = { port = 65536 }\ncapture.ring_frames = 3\n')
    write(h, "flags.txt", "--server.port=0\n--capture.fps=1e3\n--pipeline.dense=no\n"
          "--jobs.queue=100000\n--retention.max_age_s=9223372036854775807\n"
          "--limits.max_frame_pixels=0x10\n")


def tar_upload_seeds():
    h = "tar_upload"
    write(h, "burst.tar", burst_tar())
    write(h, "burst-in-dir.tar", burst_tar(top="burst/", directories=True))
    write(h, "burst-color-gnu.tar", burst_tar(channels=3, tar_format=tarfile.GNU_FORMAT))
    write(h, "burst-dot-slash.tar", burst_tar(top="./"))
    for name, tar_format in (("pax", tarfile.PAX_FORMAT), ("gnu", tarfile.GNU_FORMAT)):
        write(h, f"burst-{name}-long-name.tar", burst_tar(top="b" * 120 + "/", tar_format=tar_format))
    truncated = burst_tar()
    write(h, "truncated.tar", truncated[:700])


def http_seeds():
    h = "http"
    auth = f"Authorization: Bearer {TOKEN}\r\n"

    def request(method, target, body=b"", headers="", with_auth=True):
        head = f"{method} {target} HTTP/1.1\r\nHost: localhost\r\n"
        if with_auth:
            head += auth
        head += headers
        if body:
            head += f"Content-Length: {len(body)}\r\n"
        return head.encode() + b"\r\n" + body

    seeds = {
        "healthz": request("GET", "/healthz", with_auth=False),
        "readyz": request("GET", "/readyz", with_auth=False),
        "metrics": request("GET", "/metrics"),
        "openapi": request("GET", "/api/v1/openapi.json", with_auth=False),
        "camera": request("GET", "/api/v1/camera"),
        "snapshot": request("GET", "/api/v1/snapshot.jpg"),
        "calibration": request("GET", "/api/v1/calibration"),
        "capture-last": request("POST", "/api/v1/captures", b'{"frames": 4, "when": "last"}',
                                "Content-Type: application/json\r\n"),
        "capture-next": request("POST", "/api/v1/captures",
                                b'{"frames": 3, "when": "next", "planes": 64, "grid": 8, '
                                b'"init": "naive", "dense": false, "keep_burst": false}',
                                "Content-Type: application/json\r\n"),
        "capture-empty": request("POST", "/api/v1/captures"),
        "capture-chunked": request("POST", "/api/v1/captures", headers=(
            "Transfer-Encoding: chunked\r\nContent-Type: application/json\r\n"))
        + b"d\r\n{\"frames\": 4}\r\n0\r\n\r\n",
        "upload": request("POST", "/api/v1/jobs?frames=3&planes=32&dense=false", burst_tar(),
                          "Content-Type: application/x-tar\r\n"),
        "upload-expect": request("POST", "/api/v1/jobs", burst_tar(top="b/"),
                                 "Content-Type: application/octet-stream\r\n"
                                 "Expect: 100-continue\r\n"),
        "upload-json": request("POST", "/api/v1/jobs", b"{}", "Content-Type: application/json\r\n"),
        "list": request("GET", "/api/v1/jobs?limit=2&status=succeeded"),
        "list-after": request("GET", "/api/v1/jobs?after={J2}&limit=1"),
        "job-processing": request("GET", "/api/v1/jobs/{J0}"),
        "job-succeeded": request("GET", "/api/v1/jobs/{J1}"),
        "job-failed": request("GET", "/api/v1/jobs/{J2}"),
        "job-queued": request("GET", "/api/v1/jobs/{J3}"),
        "delete-processing": request("DELETE", "/api/v1/jobs/{J0}"),
        "delete-succeeded": request("DELETE", "/api/v1/jobs/{J1}"),
        "delete-queued": request("DELETE", "/api/v1/jobs/{J3}"),
        "delete-unknown": request("DELETE", "/api/v1/jobs/j0000000000000-0000"),
        "file-result": request("GET", "/api/v1/jobs/{J1}/result.json"),
        "file-depth-png": request("GET", "/api/v1/jobs/{J1}/depth.png"),
        "file-not-produced": request("GET", "/api/v1/jobs/{J1}/depth.tiff"),
        "file-burst": request("GET", "/api/v1/jobs/{J1}/burst.tar"),
        "file-burst-dropped": request("GET", "/api/v1/jobs/{J2}/burst.tar"),
        "file-not-finished": request("GET", "/api/v1/jobs/{J0}/calibration.yaml"),
        "file-unknown": request("GET", "/api/v1/jobs/{J1}/job.json"),
        "file-range": request("GET", "/api/v1/jobs/{J1}/points.ply", headers="Range: bytes=0-9\r\n"),
        "file-ranges": request("GET", "/api/v1/jobs/{J1}/depth.png",
                               headers="Range: bytes=0-" + ",0-" * 200 + "\r\n"),
        "file-range-suffix": request("HEAD", "/api/v1/jobs/{J1}/result.json",
                                     headers="Range: bytes=-7\r\n"),
        "file-range-unsatisfiable": request("GET", "/api/v1/jobs/{J1}/result.json",
                                            headers="Range: bytes=99999999-\r\n"),
        "file-gate-range": request("GET", "/api/v1/jobs/{J1}/result.json",
                                   headers="Dfsm-Range: 3-4\r\nIf-Range: \"x\"\r\n"),
        "www-ranges": request("HEAD", "/ui/index.html", with_auth=False,
                              headers="Range: bytes=0-,0-,0-,5-9\r\n"),
        "upload-range": request("POST", "/api/v1/jobs?camera=capture", burst_tar(),
                                "Content-Type: application/x-tar\r\n"
                                "Content-Range: bytes 0-9/10\r\n"),
        "head-file": request("HEAD", "/api/v1/jobs/{J1}/confidence.png"),
        "path-trick": request("GET", "/api/v1/jobs/..%2F..%2Fetc/result.json"),
        "preflight": request("OPTIONS", "/api/v1/jobs", with_auth=False, headers=(
            "Origin: https://viewer.example\r\nAccess-Control-Request-Method: POST\r\n")),
        "no-token": request("GET", "/api/v1/jobs", with_auth=False),
        "wrong-token": request("GET", "/api/v1/camera", with_auth=False,
                               headers="Authorization: Bearer fuzz-tokeN\r\n"),
        "basic-auth": request("GET", "/metrics", with_auth=False,
                              headers="Authorization: Basic Zm9vOmJhcg==\r\n"),
        "unknown-route": request("GET", "/api/v2/jobs"),
        "wrong-method": request("PUT", "/api/v1/jobs/{J1}", b"x"),
        "bad-query": request("GET", "/api/v1/jobs?limit=-1&limit=5&status=done"),
        "keep-alive": request("GET", "/healthz", with_auth=False)
        + request("POST", "/api/v1/captures") + request("GET", "/api/v1/jobs?limit=1"),
    }
    for name, data in seeds.items():
        write(h, name + ".http", data)


def frame_convert_seeds():
    """Layout bytes (format, width-1, height-1, padding, colour) + buffer."""
    h = "frame_convert"
    formats = {"yuyv": 0, "uyvy": 1, "nv12": 2, "yu12": 3, "grey": 4, "rgb24": 5, "bgr24": 6}
    sizes = {"yuyv": 2 * 16 * 8, "uyvy": 2 * 16 * 8, "nv12": 16 * 8 * 3 // 2,
             "yu12": 16 * 8 * 3 // 2, "grey": 16 * 8, "rgb24": 3 * 16 * 8, "bgr24": 3 * 16 * 8}
    for name, index in formats.items():
        data = bytes((i * 7) % 256 for i in range(sizes[name]))
        write(h, f"{name}-16x8-color.bin", bytes([index, 15, 7, 0, 1]) + data)
        write(h, f"{name}-16x8-gray.bin", bytes([index, 15, 7, 0, 0]) + data)
    # Padded rows (stride 20 for a 16-pixel gray row), odd sizes, a short frame.
    write(h, "grey-padded.bin", bytes([4, 15, 7, 4, 1]) + bytes(20 * 8))
    write(h, "yu12-odd.bin", bytes([3, 14, 6, 2, 1]) + bytes(17 * 7 + 2 * 8 * 4))
    write(h, "yuyv-short.bin", bytes([0, 15, 7, 0, 1]) + bytes(100))
    write(h, "h264.bin", bytes([9, 15, 7, 0, 1]) + bytes(64))


if __name__ == "__main__":
    burst_manifest_seeds()
    config_seeds()
    tar_upload_seeds()
    http_seeds()
    frame_convert_seeds()
