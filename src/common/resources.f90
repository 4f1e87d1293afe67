!> Resources of this process and its node: the peak resident set size (POSIX getrusage; Linux
!> reports ru_maxrss in kilobytes) and the memory still available to it (Linux: MemAvailable of
!> /proc/meminfo, bounded by the cgroup limit a batch system sets, cgroup v2 or v1).
module beadmob_resources
  use, intrinsic :: iso_c_binding, only: c_int, c_long
  use beadmob_kinds, only: dp
  implicit none
  private
  public :: peak_resident_bytes, available_memory_bytes, online_processors

  type, bind(c) :: c_timeval
    integer(c_long) :: seconds, microseconds
  end type c_timeval

  type, bind(c) :: c_rusage
    type(c_timeval) :: user_time, system_time
    integer(c_long) :: maxrss, ixrss, idrss, isrss, minflt, majflt, nswap, inblock, oublock, msgsnd, msgrcv, &
                       nsignals, nvcsw, nivcsw
  end type c_rusage

  interface
    integer(c_long) function c_sysconf(name) bind(c, name='sysconf')
      import :: c_int, c_long
      integer(c_int), value :: name
    end function c_sysconf
    integer(c_int) function c_getrusage(who, usage) bind(c, name='getrusage')
      import :: c_int, c_rusage
      integer(c_int), value :: who
      type(c_rusage), intent(out) :: usage
    end function c_getrusage
  end interface

contains

  !> Peak resident set size of this process so far, bytes (0 if unavailable).
  real(dp) function peak_resident_bytes()
    type(c_rusage) :: usage
    integer(c_int), parameter :: rusage_self = 0
    peak_resident_bytes = 0.0_dp
    if (c_getrusage(rusage_self, usage) == 0) peak_resident_bytes = real(usage%maxrss, dp) * 1024.0_dp
  end function peak_resident_bytes

  !> Processors online on this node (sysconf _SC_NPROCESSORS_ONLN, 84 on Linux; 1 if unknown).
  integer function online_processors()
    integer(c_int), parameter :: processors_online = 84
    online_processors = max(1, int(c_sysconf(processors_online)))
  end function online_processors

  !> Bytes of memory this node can still give (0 if unknown): MemAvailable, and when a cgroup
  !> limits the job (Slurm, containers) the limit less the group's current use, if smaller.
  real(dp) function available_memory_bytes()
    real(dp) :: limit, used
    available_memory_bytes = meminfo_value('MemAvailable:') * 1024.0_dp
    limit = file_number('/sys/fs/cgroup/memory.max')                     ! cgroup v2
    used = file_number('/sys/fs/cgroup/memory.current')
    if (limit <= 0.0_dp) then                                              ! cgroup v1
      limit = file_number('/sys/fs/cgroup/memory/memory.limit_in_bytes')
      used = file_number('/sys/fs/cgroup/memory/memory.usage_in_bytes')
    end if
    ! v1 reports "no limit" as a huge number; anything above 1 EB counts as none.
    if (limit > 0.0_dp .and. limit < 1.0e18_dp) then
      if (available_memory_bytes > 0.0_dp) then
        available_memory_bytes = min(available_memory_bytes, max(limit - used, 0.0_dp))
      else
        available_memory_bytes = max(limit - used, 0.0_dp)
      end if
    end if
  end function available_memory_bytes

  !> The number on the line of /proc/meminfo that starts with `key` (kB), 0 if absent.
  real(dp) function meminfo_value(key)
    character(len=*), intent(in) :: key
    character(len=256) :: line
    integer :: unit, status
    meminfo_value = 0.0_dp
    open (newunit=unit, file='/proc/meminfo', status='old', action='read', iostat=status)
    if (status /= 0) return
    do
      read (unit, '(a)', iostat=status) line
      if (status /= 0) exit
      if (index(line, key) == 1) then
        read (line(len(key) + 1:), *, iostat=status) meminfo_value
        if (status /= 0) meminfo_value = 0.0_dp
        exit
      end if
    end do
    close (unit)
  end function meminfo_value

  !> The number a one-line file holds, 0 if the file is absent or holds no number ("max").
  real(dp) function file_number(path)
    character(len=*), intent(in) :: path
    integer :: unit, status
    file_number = 0.0_dp
    open (newunit=unit, file=path, status='old', action='read', iostat=status)
    if (status /= 0) return
    read (unit, *, iostat=status) file_number
    if (status /= 0) file_number = 0.0_dp
    close (unit)
  end function file_number
end module beadmob_resources
