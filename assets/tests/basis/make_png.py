# Writes the source images of the Basis Universal test textures (32×32 RGBA PNG).
import math, struct, zlib
def png(path, w, h, pixel):
    rows = b''.join(b'\0' + b''.join(bytes(pixel(x, y)) for x in range(w)) for y in range(h))
    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data) & 0xffffffff)
    open(path, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 6, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(rows, 9)) + chunk(b'IEND', b''))
N = 32
def colour(x, y):
    u, v = x / N, y / N
    checker = 50 if (x // 8 + y // 8) % 2 == 0 else 0
    return [int(u * 180) + checker, int(v * 150 + 40), int((1 - u) * 120) + checker, 255]
def normal_xyz(x, y):
    a, b = (x + 0.5) / N * math.tau * 2, (y + 0.5) / N * math.tau * 2
    n = (-0.6 * math.cos(a) * math.sin(b), -0.6 * math.sin(a) * math.cos(b), 1.0)
    l = math.sqrt(sum(c * c for c in n))
    return [round((c / l * 0.5 + 0.5) * 255) for c in n]
png('colour.png', N, N, colour)
png('normal.png', N, N, lambda x, y: normal_xyz(x, y) + [255])
# Basis Universal's two-channel normal-map layout (KHR_texture_basisu): X in RGB, Y in alpha.
png('normal_rrrg.png', N, N, lambda x, y: [normal_xyz(x, y)[0]] * 3 + [normal_xyz(x, y)[1]])
