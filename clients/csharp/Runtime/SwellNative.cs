// The native model, as an option: P/Invoke bindings to crates/swell-ffi (the C ABI over the very
// code the server runs), for what the managed port (Surface.cs) does not evaluate: FFT and
// particle layers, every query field at once, orientation. Ship the library beside the game:
// libswell_ffi.so (Linux, Android), swell_ffi.dll (Windows), libswell_ffi.dylib (macOS), built
// with `cargo build --release -p swell-ffi`. On iOS and WebGL, where plugins link statically,
// build the staticlib and define SWELL_NATIVE_INTERNAL so the bindings name "__Internal".
//
// Only this file touches the library: nothing else in the package needs it, and a game that
// never constructs a NativeSurface never loads it.
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Swell
{
    /// <summary>An error the native library reported: its SWELL_ERR_* code and message.</summary>
    public sealed class SwellNativeException : Exception
    {
        /// <summary>The SWELL_ERR_* code (1 null, 2 bad JSON, 3 invalid spec, 4 invalid argument,
        /// 5 not found, 6 unsupported, 7 a panic caught at the boundary).</summary>
        public int Code { get; private set; }

        internal SwellNativeException(int code, string message) : base(message) { Code = code; }
    }

    /// <summary>One point's answers from the native model (fields not asked read 0, the normal
    /// straight up, the Jacobian 1).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct NativePoint
    {
        /// <summary>Elevation of the surface above the world point, m.</summary>
        public double Height;
        /// <summary>Unit normal x, y, z of the displaced surface.</summary>
        public double NormalX, NormalY, NormalZ;
        /// <summary>Displacement (Dx, y, Dz) of the point taken as undisplaced, m.</summary>
        public double DisplacementX, DisplacementY, DisplacementZ;
        /// <summary>Jacobian determinant of the horizontal map at the source point.</summary>
        public double Jacobian;
        /// <summary>Inversion residual, m.</summary>
        public double Residual;
        /// <summary>1 where the surface folds.</summary>
        public int Folded;
    }

    /// <summary>Which answers a native query computes (SWELL_FIELD_*), combinable with |.</summary>
    [Flags]
    public enum NativeFields : uint
    {
        /// <summary>Height with inversion of the horizontal displacement.</summary>
        Height = 1,
        /// <summary>Unit normal of the displaced surface.</summary>
        Normal = 2,
        /// <summary>Displacement of the point taken as undisplaced.</summary>
        Displacement = 4,
        /// <summary>Jacobian determinant and fold flag.</summary>
        Jacobian = 8,
        /// <summary>Inversion residual.</summary>
        Residual = 16,
        /// <summary>Every field.</summary>
        All = 31,
    }

    /// <summary>
    /// A scene built by the native model from its spec JSON (what PUT /v1/scenes/{id} takes, or
    /// the <c>spec</c> of GET /v1/scenes/{id}). Queries give the server's bits for every layer
    /// kind. Dispose it to free the native handle.
    /// </summary>
    public sealed class NativeSurface : IDisposable
    {
#if SWELL_NATIVE_INTERNAL
        const string Lib = "__Internal";
#else
        const string Lib = "swell_ffi";
#endif

        [DllImport(Lib)] static extern uint swell_model_version();
        [DllImport(Lib)] static extern IntPtr swell_last_error_message();
        [DllImport(Lib)] static extern int swell_surface_new(byte[] json, UIntPtr len, out IntPtr surface);
        [DllImport(Lib)] static extern void swell_surface_free(IntPtr surface);
        [DllImport(Lib)] static extern int swell_surface_sample(IntPtr surface, double t, double[] points, UIntPtr n, uint fields, IntPtr options, [Out] NativePoint[] output);
        [DllImport(Lib)] static extern int swell_surface_height(IntPtr surface, double t, double x, double z, out double height);

        IntPtr handle;

        /// <summary>The model version of the library's numbers (the server's MODEL_VERSION).</summary>
        public static uint ModelVersion { get { return swell_model_version(); } }

        /// <summary>Builds the scene. Throws <see cref="SwellNativeException"/> for bad JSON or
        /// a spec the model rejects (the message names the field).</summary>
        public NativeSurface(string specJson)
        {
            if (specJson == null) throw new ArgumentNullException("specJson");
            byte[] bytes = Encoding.UTF8.GetBytes(specJson);
            Check(swell_surface_new(bytes, (UIntPtr)bytes.Length, out handle));
        }

        /// <summary>Answers <paramref name="fields"/> at world points <c>xz</c> (x0, z0, x1, z1, …)
        /// at scene time t, with the server's default accuracy.</summary>
        public NativePoint[] Sample(double t, double[] xz, NativeFields fields)
        {
            if (xz == null || xz.Length % 2 != 0) throw new ArgumentException("xz holds x, z pairs", "xz");
            var output = new NativePoint[xz.Length / 2];
            Check(swell_surface_sample(Live(), t, xz, (UIntPtr)output.Length, (uint)fields, IntPtr.Zero, output));
            return output;
        }

        /// <summary>Height at world (x, z) at scene time t, m (the server's /height).</summary>
        public double Height(double t, double x, double z)
        {
            double h;
            Check(swell_surface_height(Live(), t, x, z, out h));
            return h;
        }

        /// <summary>Frees the native scene; later calls throw ObjectDisposedException.</summary>
        public void Dispose()
        {
            if (handle != IntPtr.Zero) swell_surface_free(handle);
            handle = IntPtr.Zero;
            GC.SuppressFinalize(this);
        }

        /// <summary>Frees the handle if Dispose was not called.</summary>
        ~NativeSurface() { if (handle != IntPtr.Zero) swell_surface_free(handle); }

        IntPtr Live()
        {
            if (handle == IntPtr.Zero) throw new ObjectDisposedException("NativeSurface");
            return handle;
        }

        static void Check(int status)
        {
            if (status == 0) return;
            IntPtr m = swell_last_error_message();
            string message = m == IntPtr.Zero ? "swell_ffi error " + status : Utf8(m);
            throw new SwellNativeException(status, message);
        }

        // Marshal.PtrToStringUTF8 is not in every profile Unity and Mono ship.
        static string Utf8(IntPtr p)
        {
            int n = 0;
            while (Marshal.ReadByte(p, n) != 0) n++;
            var bytes = new byte[n];
            Marshal.Copy(p, bytes, 0, n);
            return Encoding.UTF8.GetString(bytes);
        }
    }
}
