//! When a frame reached the subscriber's socket, as opposed to when the tool got round to reading
//! it.
//!
//! The tool reads every subscriber's socket on the same cores as the server it measures: with a
//! thousand subscribers a frame can sit in its socket for milliseconds while the tool decodes the
//! frames of the other 999. That wait is the tool's, not the server's. On Linux the kernel stamps
//! each received packet (`SO_TIMESTAMPNS`, software receive timestamps) and hands the stamp of the
//! last packet a `recvmsg` read back with the data; [`TimedTcp`] keeps the stamp of its latest
//! read, so a WebSocket message's stamp is the time its last byte reached the socket. On loopback
//! the stamp is taken as the server's `send` hands the packet over.
//!
//! Elsewhere (or if the kernel refuses the option) there is no stamp and the report says the
//! delivery delay is the read time.

use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use std::time::{Duration, Instant, SystemTime};

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;

/// A TCP stream that remembers the kernel's receive time of the data it read last.
///
/// On Linux it reads through [`AsyncFd`](tokio::io::unix::AsyncFd), to use `recvmsg` and, like
/// tokio's own `TcpStream`, to take a short read as proof the socket is drained (no second
/// `read` that only finds it empty: that was half the tool's system calls). Elsewhere it is a
/// plain tokio `TcpStream` without stamps.
#[derive(Debug)]
pub struct TimedTcp {
    #[cfg(target_os = "linux")]
    inner: tokio::io::unix::AsyncFd<std::net::TcpStream>,
    #[cfg(not(target_os = "linux"))]
    inner: TcpStream,
    stamped: bool,
    last_rx: Option<SystemTime>,
}

impl TimedTcp {
    /// Wraps `tcp`; with `stamp`, asks the kernel for receive timestamps (Linux only). Whether
    /// it agreed is [`TimedTcp::stamped`].
    ///
    /// # Errors
    /// The socket could not be moved to the reactor.
    pub fn new(tcp: TcpStream, stamp: bool) -> io::Result<Self> {
        #[cfg(target_os = "linux")]
        {
            let std = tcp.into_std()?;
            let stamped = stamp && enable(&std);
            // SAFETY: a std TcpStream owns its descriptor, open until the stream is dropped
            // (with the AsyncFd), and `as_raw_fd` always returns that one.
            let inner = unsafe { tokio::io::unix::AsyncFd::register(std) }
                .map_err(|e| io::Error::other(e.to_string()))?;
            Ok(Self {
                inner,
                stamped,
                last_rx: None,
            })
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = stamp;
            Ok(Self {
                inner: tcp,
                stamped: false,
                last_rx: None,
            })
        }
    }

    /// Whether reads carry the kernel's receive time.
    pub fn stamped(&self) -> bool {
        self.stamped
    }

    /// The kernel's receive time (real-time clock) of the last packet the latest read took data
    /// from; `None` when that read carried no stamp. The kernel switches stamping on shortly
    /// after the first socket asks (a deferred switch shared by every socket), so packets that
    /// arrive within the first moments after [`TimedTcp::new`] may come without one.
    pub fn last_rx(&self) -> Option<SystemTime> {
        self.last_rx
    }
}

#[cfg(target_os = "linux")]
fn enable(s: &std::net::TcpStream) -> bool {
    use std::os::fd::AsRawFd as _;
    let on: libc::c_int = 1;
    // SAFETY: a valid socket descriptor and a c_int option of the size given.
    let r = unsafe {
        libc::setsockopt(
            s.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_TIMESTAMPNS,
            (&raw const on).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    r == 0
}

/// One `recvmsg` into `buf`: bytes read, and the receive timestamp the kernel attached.
#[cfg(target_os = "linux")]
fn recv_stamped(
    s: &std::net::TcpStream,
    buf: &mut [u8],
) -> io::Result<(usize, Option<SystemTime>)> {
    use std::os::fd::AsRawFd as _;
    let mut iov = libc::iovec {
        iov_base: buf.as_mut_ptr().cast(),
        iov_len: buf.len(),
    };
    // Room for one SCM_TIMESTAMPNS (a 16-byte header and a 16-byte timespec) and then some;
    // u64s for the alignment cmsg headers need.
    let mut control = [0u64; 16];
    // SAFETY: msghdr is plain data; every pointer set below outlives the call.
    let mut msg: libc::msghdr = unsafe { std::mem::zeroed() };
    msg.msg_iov = &raw mut iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control.as_mut_ptr().cast();
    msg.msg_controllen = std::mem::size_of_val(&control) as _;
    // SAFETY: `msg` points at a live iovec over `buf` and at `control`, both writable.
    let n = unsafe { libc::recvmsg(s.as_raw_fd(), &raw mut msg, 0) };
    if n < 0 {
        return Err(io::Error::last_os_error());
    }
    let mut stamp = None;
    // SAFETY: the CMSG_* walk stays inside `control` as the kernel filled it (msg_controllen
    // was updated to what it wrote); the timespec is read unaligned from the cmsg's data.
    unsafe {
        let mut c = libc::CMSG_FIRSTHDR(&raw const msg);
        while !c.is_null() {
            if (*c).cmsg_level == libc::SOL_SOCKET && (*c).cmsg_type == libc::SCM_TIMESTAMPNS {
                let ts: libc::timespec = std::ptr::read_unaligned(libc::CMSG_DATA(c).cast());
                let (secs, nanos) = (u64::try_from(ts.tv_sec), u32::try_from(ts.tv_nsec));
                if let (Ok(secs), Ok(nanos)) = (secs, nanos) {
                    stamp = Some(SystemTime::UNIX_EPOCH + Duration::new(secs, nanos));
                }
            }
            c = libc::CMSG_NXTHDR(&raw const msg, c);
        }
    }
    Ok((n as usize, stamp))
}

#[cfg(target_os = "linux")]
impl AsyncRead for TimedTcp {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        use std::io::Read as _;
        let this = self.get_mut();
        let stamped = this.stamped;
        loop {
            let mut guard = ready!(this.inner.poll_read_ready(cx))?;
            // tungstenite hands over an initialised buffer, so this zeroes nothing.
            let unfilled = buf.initialize_unfilled();
            let room = unfilled.len();
            let read = guard.try_io(|s| {
                if stamped {
                    recv_stamped(s.get_ref(), unfilled)
                } else {
                    s.get_ref().read(unfilled).map(|n| (n, None))
                }
            });
            match read {
                Ok(Ok((n, stamp))) => {
                    // A short read drained the socket: wait for the next readiness event
                    // rather than read again to be told so (what tokio's TcpStream does).
                    if n > 0 && n < room {
                        guard.clear_ready();
                    }
                    buf.advance(n);
                    if n > 0 {
                        // Never an older read's stamp for newer data.
                        this.last_rx = stamp;
                    }
                    return Poll::Ready(Ok(()));
                }
                Ok(Err(e)) => return Poll::Ready(Err(e)),
                // Readiness was stale: `try_io` cleared it, so the next poll waits for more.
                Err(_would_block) => {}
            }
        }
    }
}

#[cfg(target_os = "linux")]
impl AsyncWrite for TimedTcp {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        use std::io::Write as _;
        let this = self.get_mut();
        loop {
            let mut guard = ready!(this.inner.poll_write_ready(cx))?;
            if let Ok(r) = guard.try_io(|s| s.get_ref().write(buf)) {
                return Poll::Ready(r);
            }
        }
    }

    fn poll_flush(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }

    fn poll_shutdown(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(
            match self.inner.get_ref().shutdown(std::net::Shutdown::Write) {
                Err(e) if e.kind() != io::ErrorKind::NotConnected => Err(e),
                _ => Ok(()),
            },
        )
    }
}

#[cfg(not(target_os = "linux"))]
impl AsyncRead for TimedTcp {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_read(cx, buf)
    }
}

#[cfg(not(target_os = "linux"))]
impl AsyncWrite for TimedTcp {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().inner).poll_write(cx, buf)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_shutdown(cx)
    }
}

/// Maps the real-time clock (kernel stamps) onto [`Instant`] (everything else the tool times),
/// from one pair of readings taken back to back. Both clocks run at the same rate over a run;
/// a step of the real-time clock during the run (an NTP jump) would shift the stamps.
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    instant: Instant,
    system: SystemTime,
}

impl WallClock {
    /// Reads both clocks now: of a few tries, the one whose real-time reading sat between the
    /// two closest monotonic readings (a thread preempted between two reads would otherwise
    /// skew every stamp by the preemption), at their midpoint.
    pub fn now() -> Self {
        let mut best: Option<(Duration, Self)> = None;
        for _ in 0..5 {
            let before = Instant::now();
            let system = SystemTime::now();
            let after = Instant::now();
            let gap = after - before;
            if best.as_ref().is_none_or(|(g, _)| gap < *g) {
                let instant = before + gap / 2;
                best = Some((gap, Self { instant, system }));
            }
        }
        best.expect("five tries").1
    }

    /// The [`Instant`] of real-time `t`.
    pub fn instant_of(&self, t: SystemTime) -> Instant {
        match t.duration_since(self.system) {
            Ok(after) => self.instant + after,
            Err(e) => self
                .instant
                .checked_sub(e.duration())
                .unwrap_or(self.instant),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};

    /// Data written to a loopback socket reads back whole, with a kernel stamp between the
    /// write and the read (on Linux), mapped onto the monotonic clock.
    #[tokio::test]
    async fn reads_carry_the_kernel_receive_time() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let client = TcpStream::connect(addr).await.unwrap();
        let (mut server, _) = listener.accept().await.unwrap();
        let mut timed = TimedTcp::new(client, true).unwrap();
        assert_eq!(timed.stamped(), cfg!(target_os = "linux"));
        assert_eq!(timed.last_rx(), None);
        let clock = WallClock::now();
        let mut got = [0u8; 64];
        // The kernel turns stamping on a moment after the first socket asks (in a fresh test
        // process, this one): the first packets may come unstamped, never wrongly stamped.
        for attempt in 0.. {
            let before = Instant::now();
            server.write_all(b"a frame's bytes").await.unwrap();
            tokio::time::sleep(Duration::from_millis(20)).await;
            let n = timed.read(&mut got).await.unwrap();
            let after_read = Instant::now();
            assert_eq!(&got[..n], b"a frame's bytes");
            if !cfg!(target_os = "linux") {
                assert_eq!(timed.last_rx(), None);
                break;
            }
            let Some(stamp) = timed.last_rx() else {
                assert!(attempt < 50, "no stamp after {attempt} reads");
                continue;
            };
            let at = clock.instant_of(stamp);
            // Stamped when it arrived, ~20 ms before it was read (a millisecond of slack for
            // the two clocks' pairing).
            assert!(
                at + Duration::from_millis(1) >= before,
                "stamp before the write"
            );
            assert!(
                at + Duration::from_millis(15) <= after_read,
                "stamp is the read time, not the arrival: {:?} before the read",
                after_read - at
            );
            break;
        }
        // Writes pass through; end of stream reads as 0.
        timed.write_all(b"back").await.unwrap();
        let mut back = [0u8; 4];
        server.read_exact(&mut back).await.unwrap();
        assert_eq!(&back, b"back");
        drop(server);
        assert_eq!(timed.read(&mut got).await.unwrap(), 0);
    }
}
