!> Triangle meshes as particle geometry: STL (ascii and binary) and OBJ files
!> read into one vertex list, checked to bound a solid (closed, every edge between exactly two
!> consistently oriented triangles), and filled on the bead lattice.
!>
!> Fill: a lattice node (integer coordinates after scaling the mesh to bead diameters) is inside
!> when the winding number of the surface about it is nonzero. Along each lattice column (x, y)
!> a ray in +z crosses the triangles whose projection covers (x, y); a crossing through a triangle
!> facing down (outward normal n_z < 0) enters the solid (+1), one facing up leaves it (-1), so the
!> winding number at height z is the sum of the crossings below z. The nonzero rule gives the
!> same nodes as an inside test of the continuum body wherever the surface does not graze a lattice
!> node; a column that ends with a nonzero sum crosses a hole or a self-intersection and is an
!> error. The rays pass (x, y) + (1, sqrt 2) 1e-9 (d): a column exactly on an edge or vertex
!> projection is never counted twice or missed.
module beadmob_triangle_mesh
  use, intrinsic :: iso_fortran_env, only: int16, int32, real32
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, str_significant, lower_case
  use beadmob_spatial_index, only: sort_keys, lower_bound
  use beadmob_lattice_fill, only: reserve_sites, lattice_shift
  implicit none
  private
  public :: triangle_mesh_t, read_triangle_mesh, check_closed_mesh, fill_mesh_on_lattice

  type :: triangle_mesh_t
    real(dp), allocatable :: vertices(:, :)    ! (3, n_vertices)
    integer, allocatable :: triangles(:, :)    ! (3, n_triangles), vertex indices
  end type triangle_mesh_t

  !> The offset of the rays from the lattice columns (d), see the module header.
  real(dp), parameter :: ray_offset(2) = [1.0e-9_dp, 1.4142135623730951e-9_dp]

contains

  !> Reads `path` (format by extension: .stl or .obj, any case), shared vertices merged.
  subroutine read_triangle_mesh(path, mesh, err)
    character(len=*), intent(in) :: path
    type(triangle_mesh_t), intent(out) :: mesh
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: extension
    real(dp), allocatable :: corners(:, :)
    logical :: exists
    integer :: dot
    inquire (file=path, exist=exists)
    if (.not. exists) then
      call raise(err, "mesh file '" // path // "' does not exist")
      return
    end if
    dot = index(path, '.', back=.true.)
    extension = ''
    if (dot > 0) extension = lower_case(path(dot + 1:))
    select case (extension)
    case ('stl')
      call read_stl(path, corners, err)
      if (.not. err%failed) call merge_corners(corners, mesh)
    case ('obj')
      call read_obj(path, mesh, err)
    case default
      call raise(err, "mesh file '" // path // "': unknown format '." // extension // "' (.stl or .obj)")
    end select
    if (err%failed) return
    if (size(mesh%triangles, 2) == 0) call raise(err, "mesh file '" // path // "' holds no triangles")
  end subroutine read_triangle_mesh

  !> STL: binary when the size is 84 + 50 n for the count n in bytes 81-84, else ascii.
  !> corners(3, 3 n): the three corners of each triangle in turn.
  subroutine read_stl(path, corners, err)
    character(len=*), intent(in) :: path
    real(dp), allocatable, intent(out) :: corners(:, :)
    type(error_t), intent(inout) :: err
    integer :: unit, stat
    integer(i8) :: bytes
    integer(int32) :: count
    character(len=80) :: header
    open (newunit=unit, file=path, access='stream', form='unformatted', status='old', action='read', iostat=stat)
    if (stat /= 0) then
      call raise(err, "mesh file '" // path // "' cannot be opened")
      return
    end if
    inquire (unit=unit, size=bytes)
    count = -1
    if (bytes >= 84) read (unit, iostat=stat) header, count
    if (count >= 0 .and. bytes == 84_i8 + 50_i8 * count) then
      call read_binary_triangles()
      close (unit)
    else
      close (unit)
      call read_ascii_stl(path, corners, err)
    end if

  contains

    subroutine read_binary_triangles()
      real(real32) :: record(12)
      integer(int16) :: attribute
      integer :: t
      allocate (corners(3, 3 * count))
      do t = 1, count
        read (unit, iostat=stat) record, attribute
        if (stat /= 0) then
          call raise(err, "mesh file '" // path // "': binary STL ends in triangle " // str(t))
          return
        end if
        corners(:, 3 * t - 2:3 * t) = reshape(real(record(4:12), dp), [3, 3])   ! record(1:3): the normal
      end do
    end subroutine read_binary_triangles
  end subroutine read_stl

  !> ascii STL: the `vertex x y z` lines, three per facet; anything else is structure or ignored.
  subroutine read_ascii_stl(path, corners, err)
    character(len=*), intent(in) :: path
    real(dp), allocatable, intent(out) :: corners(:, :)
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: line
    character(len=16) :: keyword
    real(dp), allocatable :: buffer(:, :)
    integer :: unit, stat, n, line_number
    call open_text(path, unit, err)
    if (err%failed) return
    allocate (buffer(3, 3 * 1024))
    n = 0
    line_number = 0
    do while (next_line(unit, line, line_number))
      if (lower_case(line(1:min(7, len(line)))) /= 'vertex ') cycle
      if (n == size(buffer, 2)) buffer = reshape(buffer, [3, 2 * n], pad=[0.0_dp])
      n = n + 1
      read (line, *, iostat=stat) keyword, buffer(:, n)
      if (stat /= 0 .or. any(buffer(:, n) /= buffer(:, n))) then
        call raise(err, "mesh file '" // path // "', line " // str(line_number) // ": not a vertex: '" // &
                   trim(line) // "'")
        close (unit)
        return
      end if
    end do
    close (unit)
    if (mod(n, 3) /= 0) then
      call raise(err, "mesh file '" // path // "': " // str(n) // ' vertex lines, not three per facet')
      return
    end if
    corners = buffer(:, 1:n)
  end subroutine read_ascii_stl

  !> OBJ: `v x y z` vertices and `f a b c ...` faces (indices from 1, negative from the end,
  !> `a/t/n` forms; polygons of any number of corners, split into a fan of triangles). Other lines
  !> (vt, vn, o, g, s, usemtl, mtllib, comments) are ignored.
  subroutine read_obj(path, mesh, err)
    character(len=*), intent(in) :: path
    type(triangle_mesh_t), intent(out) :: mesh
    type(error_t), intent(inout) :: err
    character(len=:), allocatable :: line, token
    real(dp), allocatable :: vertices(:, :)
    integer, allocatable :: triangles(:, :), face(:), starts(:), ends(:)
    integer :: unit, stat, n_vertices, n_triangles, line_number, n_tokens, k, slash, value
    real(dp), allocatable :: corners(:, :)
    call open_text(path, unit, err)
    if (err%failed) return
    allocate (vertices(3, 1024), triangles(3, 1024))
    n_vertices = 0
    n_triangles = 0
    line_number = 0
    do while (next_line(unit, line, line_number))
      if (line(1:min(2, len(line))) == 'v ') then
        if (n_vertices == size(vertices, 2)) vertices = reshape(vertices, [3, 2 * n_vertices], pad=[0.0_dp])
        n_vertices = n_vertices + 1
        read (line(3:), *, iostat=stat) vertices(:, n_vertices)
        if (stat /= 0 .or. any(vertices(:, n_vertices) /= vertices(:, n_vertices))) then
          call fail('not a vertex')
          return
        end if
      else if (line(1:min(2, len(line))) == 'f ') then
        call split(line(3:), starts, ends)
        n_tokens = size(starts)
        if (n_tokens < 3) then
          call fail('a face needs three vertices')
          return
        end if
        allocate (face(n_tokens))
        do k = 1, n_tokens
          token = line(2 + starts(k):2 + ends(k))
          slash = index(token, '/')
          if (slash > 0) token = token(1:slash - 1)
          read (token, *, iostat=stat) value
          if (stat == 0 .and. value < 0) value = n_vertices + 1 + value
          if (stat /= 0 .or. value < 1 .or. value > n_vertices) then
            call fail("vertex index '" // token // "' is not one of the " // str(n_vertices) // &
                      ' vertices read so far')
            return
          end if
          face(k) = value
        end do
        do k = 2, n_tokens - 1
          if (n_triangles == size(triangles, 2)) triangles = reshape(triangles, [3, 2 * n_triangles], pad=[0])
          n_triangles = n_triangles + 1
          triangles(:, n_triangles) = [face(1), face(k), face(k + 1)]
        end do
        deallocate (face)
      end if
    end do
    close (unit)
    ! Merge repeated vertices (exporters may repeat them per face) through the corner list.
    allocate (corners(3, 3 * n_triangles))
    do k = 1, n_triangles
      corners(:, 3 * k - 2:3 * k) = vertices(:, triangles(:, k))
    end do
    call merge_corners(corners, mesh)

  contains

    subroutine fail(what)
      character(len=*), intent(in) :: what
      call raise(err, "mesh file '" // path // "', line " // str(line_number) // ': ' // what // ": '" // &
                 trim(line) // "'")
      close (unit)
    end subroutine fail
  end subroutine read_obj

  !> The text readers' file, open for reading (an error naming it if it cannot be).
  subroutine open_text(path, unit, err)
    character(len=*), intent(in) :: path
    integer, intent(out) :: unit
    type(error_t), intent(inout) :: err
    integer :: stat
    open (newunit=unit, file=path, status='old', action='read', iostat=stat)
    if (stat /= 0) call raise(err, "mesh file '" // path // "' cannot be opened")
  end subroutine open_text

  !> The next line of `unit`, whole (an OBJ face of many corners can be kilobytes long), with tabs
  !> and the carriage return of CRLF line ends as blanks (tab-indented and Windows files), trimmed
  !> and left-adjusted; and its number. .false. at the end of the file.
  logical function next_line(unit, line, line_number)
    integer, intent(in) :: unit
    character(len=:), allocatable, intent(out) :: line
    integer, intent(inout) :: line_number
    character(len=1024) :: chunk
    integer :: stat, length, k
    line = ''
    do   ! the line in chunks, until its end (iostat_eor) or the file's
      read (unit, '(a)', advance='no', iostat=stat, size=length) chunk
      line = line // chunk(1:length)
      if (stat /= 0) exit
    end do
    ! the last line without a line end still counts
    next_line = is_iostat_eor(stat) .or. (is_iostat_end(stat) .and. len(line) > 0)
    if (.not. next_line) return
    line_number = line_number + 1
    do k = 1, len(line)
      if (line(k:k) == achar(9) .or. line(k:k) == achar(13)) line(k:k) = ' '
    end do
    line = trim(adjustl(line))
  end function next_line

  !> The blank-separated tokens of `text` (next_line made tabs blanks): token k is
  !> text(starts(k):ends(k)), as many as there are.
  subroutine split(text, starts, ends)
    character(len=*), intent(in) :: text
    integer, allocatable, intent(out) :: starts(:), ends(:)
    integer :: i, n, pass
    allocate (starts(0), ends(0))
    do pass = 1, 2   ! count, then record
      n = 0
      i = 1
      do while (i <= len(text))
        if (text(i:i) == ' ') then
          i = i + 1
          cycle
        end if
        n = n + 1
        if (pass == 2) starts(n) = i
        do while (i <= len(text))
          if (text(i:i) == ' ') exit
          i = i + 1
        end do
        if (pass == 2) ends(n) = i - 1
      end do
      if (pass == 1) then
        deallocate (starts, ends)
        allocate (starts(n), ends(n))
      end if
    end do
  end subroutine split

  !> One vertex per distinct corner position (equal coordinates: the same vertex, as exporters
  !> write shared corners), triangles by index. Sorting by a key of the coordinates' bits puts
  !> equal corners next to each other (equal keys of different corners are told apart).
  subroutine merge_corners(corners, mesh)
    real(dp), intent(in) :: corners(:, :)
    type(triangle_mesh_t), intent(out) :: mesh
    integer(i8), allocatable :: keys(:), order(:)
    integer, allocatable :: vertex_of(:)
    integer(i8) :: c, first
    integer :: n_vertices, k
    logical :: same
    allocate (keys(size(corners, 2)), order(size(corners, 2)), vertex_of(size(corners, 2)))
    do c = 1, size(corners, 2, kind=i8)
      keys(c) = position_key(corners(:, c))
      order(c) = c
    end do
    call sort_keys(keys, order)
    allocate (mesh%vertices(3, size(corners, 2)))
    n_vertices = 0
    first = 1
    do c = 1, size(keys, kind=i8)
      if (c > 1) then
        if (keys(c) /= keys(c - 1)) first = c
      end if
      ! the run of equal keys from `first`: look for an equal corner among the vertices made in it
      same = .false.
      do k = int(first), int(c) - 1
        if (all(corners(:, order(k)) == corners(:, order(c)))) then
          vertex_of(order(c)) = vertex_of(order(k))
          same = .true.
          exit
        end if
      end do
      if (same) cycle
      n_vertices = n_vertices + 1
      mesh%vertices(:, n_vertices) = corners(:, order(c))
      vertex_of(order(c)) = n_vertices
    end do
    mesh%vertices = mesh%vertices(:, 1:n_vertices)
    mesh%triangles = reshape(vertex_of, [3, size(corners, 2) / 3])
  end subroutine merge_corners

  !> A 63-bit key of a position: equal positions give equal keys.
  pure integer(i8) function position_key(p)
    real(dp), intent(in) :: p(3)
    integer(i8) :: bits(3)
    real(dp) :: q(3)
    q = p + 0.0_dp   ! -0 and +0 alike
    bits = transfer(q, bits)
    position_key = ieor(ieor(bits(1), ishftc(bits(2), 21)), ishftc(bits(3), 42))
    position_key = iand(position_key, huge(1_i8))
  end function position_key

  !> The mesh bounds a solid: no degenerate triangle, and every directed edge a -> b of a
  !> triangle is met by exactly one b -> a of another (closed, two triangles per edge, both
  !> oriented alike). The message names the first offending edge by its end points (in the
  !> file's units) and its triangle (numbered in the file's order).
  subroutine check_closed_mesh(mesh, path, err)
    type(triangle_mesh_t), intent(in) :: mesh
    character(len=*), intent(in) :: path
    type(error_t), intent(inout) :: err
    integer(i8), allocatable :: edges(:), owner(:)
    integer(i8) :: n, e, reverse, found
    integer :: t, k, a, b, digits
    n = size(mesh%vertices, 2)
    do t = 1, size(mesh%triangles, 2)
      associate (v => mesh%triangles(:, t))
        if (v(1) == v(2) .or. v(2) == v(3) .or. v(3) == v(1)) then
          ! the repeated corner, in digits that tell it from the third (the triangle's size)
          a = merge(v(1), v(2), v(1) == v(2) .or. v(1) == v(3))
          b = merge(v(3), merge(v(2), v(1), a == v(1)), v(1) == v(2))
          call raise(err, "mesh file '" // path // "': triangle " // str(t) // ' has two equal corners at ' // &
                     point_text(mesh%vertices(:, a), digits_apart(mesh%vertices(:, a), mesh%vertices(:, b))))
          return
        end if
      end associate
    end do
    allocate (edges(3 * size(mesh%triangles, 2)), owner(3 * size(mesh%triangles, 2)))
    e = 0
    do t = 1, size(mesh%triangles, 2)
      do k = 1, 3
        e = e + 1
        edges(e) = (mesh%triangles(k, t) - 1) * n + (mesh%triangles(mod(k, 3) + 1, t) - 1)
        owner(e) = t
      end do
    end do
    call sort_keys(edges, owner)
    ! First the edges used twice in one direction (a flipped triangle also leaves edges without
    ! their reverse: the more telling message first), then the edges without a reverse.
    do e = 2, size(edges, kind=i8)
      if (edges(e) /= edges(e - 1)) cycle
      a = int(edges(e) / n) + 1
      b = int(mod(edges(e), n)) + 1
      digits = digits_apart(mesh%vertices(:, a), mesh%vertices(:, b))
      call raise(err, "mesh file '" // path // "': the edge from " // point_text(mesh%vertices(:, a), digits) // &
                 ' to ' // point_text(mesh%vertices(:, b), digits) // &
                 ' is used in the same direction by triangles ' // str(owner(e - 1)) // ' and ' // str(owner(e)) // &
                 ' (more than two triangles at an edge, or triangles oriented inconsistently)')
      return
    end do
    do e = 1, size(edges, kind=i8)
      a = int(edges(e) / n) + 1
      b = int(mod(edges(e), n)) + 1
      reverse = (b - 1) * n + (a - 1)
      found = lower_bound(edges, reverse)
      if (found > size(edges, kind=i8)) found = 0
      if (found > 0) then
        if (edges(found) /= reverse) found = 0
      end if
      if (found == 0) then
        digits = digits_apart(mesh%vertices(:, a), mesh%vertices(:, b))
        call raise(err, "mesh file '" // path // "' is not closed: the edge from " // &
                   point_text(mesh%vertices(:, a), digits) // ' to ' // point_text(mesh%vertices(:, b), digits) // &
                   ' of triangle ' // str(owner(e)) // &
                   ' has no triangle on its other side (or that one is oriented the other way)')
        return
      end if
    end do
  end subroutine check_closed_mesh

  !> A point in messages, "(0.08725, 0.4459, 0.5068)": `digits` significant digits (from digits_apart).
  function point_text(p, digits) result(text)
    real(dp), intent(in) :: p(3)
    integer, intent(in) :: digits
    character(len=:), allocatable :: text
    text = '(' // str_significant(p(1), digits) // ', ' // str_significant(p(2), digits) // ', ' // &
           str_significant(p(3), digits) // ')'
  end function point_text

  !> The significant digits for coordinates in messages: 4, readable and enough to find the place,
  !> or more where 4 would print the two points p and q of a message (an edge's ends; a coordinate
  !> and its neighbouring lattice line) alike: close points far from the origin, say 1000.05 and
  !> 1000.1. 17 at most, which tell any two doubles apart.
  function digits_apart(p, q) result(digits)
    real(dp), intent(in) :: p(:), q(:)
    integer :: digits
    integer :: k
    do digits = 4, 17
      do k = 1, size(p)
        if (str_significant(p(k), digits) /= str_significant(q(k), digits)) return
      end do
    end do
    digits = 4   ! equal points: no digits tell them apart
  end function digits_apart

  !> The lattice nodes inside the mesh scaled by `scale` (mesh units -> d), in the order x
  !> fastest, then y, then z (the order of the analytic shapes), by the winding numbers of the
  !> module header. `path` names the file in errors. `offset` (d, each in [0, 1)) shifts the
  !> lattice against the body: the points node + offset inside the mesh.
  subroutine fill_mesh_on_lattice(mesh, scale, path, centres, err, offset)
    type(triangle_mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: scale
    character(len=*), intent(in) :: path
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)
    real(dp), allocatable :: points(:, :), crossing_z(:), buffer(:, :)
    integer, allocatable :: column_start(:), column_triangles(:), crossing_sign(:), fill(:)
    integer(i8), allocatable :: keys(:), order(:)
    integer :: lower(3), upper(3), width(2), t, i, j, k, column, n_columns, n_crossings, c, winding, count, slot
    real(dp) :: low(2), high(2), ray(2), w(3), z, line_xy(2)
    real(dp) :: shift(3)
    shift = lattice_shift(offset)
    ! The mesh moved by -offset and filled at the integer nodes, which then move back by +offset.
    points = scale * mesh%vertices - spread(shift, 2, size(mesh%vertices, 2))
    lower = ceiling(minval(points, dim=2))
    upper = floor(maxval(points, dim=2))
    allocate (centres(3, 0))
    if (any(upper < lower)) return   ! smaller than one lattice cell in some direction: no node
    width = upper(1:2) - lower(1:2) + 1
    n_columns = width(1) * width(2)
    ! Columns -> the triangles whose projection's box covers them (compressed rows).
    allocate (column_start(n_columns + 1), fill(n_columns))
    column_start = 0
    do t = 1, size(mesh%triangles, 2)
      call column_box(t)
      do j = int(low(2)), int(high(2))
        do i = int(low(1)), int(high(1))
          column = 1 + (i - lower(1)) + width(1) * (j - lower(2))
          column_start(column + 1) = column_start(column + 1) + 1
        end do
      end do
    end do
    column_start(1) = 1
    do column = 2, n_columns + 1
      column_start(column) = column_start(column) + column_start(column - 1)
    end do
    allocate (column_triangles(column_start(n_columns + 1) - 1))
    fill = column_start(1:n_columns)
    do t = 1, size(mesh%triangles, 2)
      call column_box(t)
      do j = int(low(2)), int(high(2))
        do i = int(low(1)), int(high(1))
          column = 1 + (i - lower(1)) + width(1) * (j - lower(2))
          column_triangles(fill(column)) = t
          fill(column) = fill(column) + 1
        end do
      end do
    end do

    call reserve_sites(upper - lower + 1, 'mesh', buffer, err)
    if (err%failed) return
    allocate (crossing_z(64), crossing_sign(64))
    count = 0
    ! Columns in y-major order; the nodes are sorted into x-fastest order at the end.
    do j = lower(2), upper(2)
      do i = lower(1), upper(1)
        column = 1 + (i - lower(1)) + width(1) * (j - lower(2))
        ray = [real(i, dp), real(j, dp)] + ray_offset
        n_crossings = 0
        do slot = column_start(column), column_start(column + 1) - 1
          t = column_triangles(slot)
          associate (a => points(:, mesh%triangles(1, t)), b => points(:, mesh%triangles(2, t)), &
                     cc => points(:, mesh%triangles(3, t)))
            w = [edge_function(b, cc, ray), edge_function(cc, a, ray), edge_function(a, b, ray)]
            if (.not. (all(w > 0.0_dp) .or. all(w < 0.0_dp))) cycle
            z = (w(1) * a(3) + w(2) * b(3) + w(3) * cc(3)) / sum(w)
            if (n_crossings == size(crossing_z)) then
              crossing_z = [crossing_z, crossing_z]
              crossing_sign = [crossing_sign, crossing_sign]
            end if
            n_crossings = n_crossings + 1
            crossing_z(n_crossings) = z
            ! counter-clockwise seen from above (w > 0): the normal points up, the ray leaves
            crossing_sign(n_crossings) = merge(-1, 1, w(1) > 0.0_dp)
          end associate
        end do
        if (n_crossings == 0) cycle
        call sort_crossings()
        if (sum(crossing_sign(1:n_crossings)) /= 0) then
          ! the column's position in the file, in digits that tell it from the next column
          line_xy = [(i + shift(1)) / scale, (j + shift(2)) / scale]
          call raise(err, "mesh file '" // path // "': the surface is not watertight where the line x = " // &
                     str_significant(line_xy(1), digits_apart(line_xy(1:1), line_xy(1:1) + 1 / scale)) // &
                     ', y = ' // str_significant(line_xy(2), digits_apart(line_xy(2:2), line_xy(2:2) + 1 / scale)) // &
                     ' (file units) crosses it: ' // &
                     str(n_crossings) // ' crossings that do not pair into entries and exits ' // &
                     '(a hole, or intersecting parts)')
          return
        end if
        winding = 0
        c = 1
        do k = lower(3), upper(3)
          do while (c <= n_crossings)
            if (crossing_z(c) > real(k, dp)) exit
            winding = winding + crossing_sign(c)
            c = c + 1
          end do
          if (winding /= 0) then
            count = count + 1
            buffer(:, count) = [real(i, dp), real(j, dp), real(k, dp)]
          end if
        end do
      end do
    end do
    ! x fastest, then y, then z
    allocate (keys(count), order(count))
    do c = 1, count
      keys(c) = int(nint(buffer(3, c)) - lower(3), i8) * n_columns + &
                (nint(buffer(2, c)) - lower(2)) * width(1) + (nint(buffer(1, c)) - lower(1))
      order(c) = c
    end do
    call sort_keys(keys, order)
    centres = buffer(:, order) + spread(shift, 2, count)

  contains

    !> low, high: the lattice columns (i, j) within the projection's box of triangle t.
    subroutine column_box(tt)
      integer, intent(in) :: tt
      real(dp) :: xy(2, 3)
      xy = points(1:2, mesh%triangles(:, tt))
      low = real(max(ceiling(minval(xy, dim=2) - ray_offset - 1.0e-6_dp), lower(1:2)), dp)
      high = real(min(floor(maxval(xy, dim=2) - ray_offset + 1.0e-6_dp), upper(1:2)), dp)
    end subroutine column_box

    !> crossings of this column sorted by height (insertion sort: few per column)
    subroutine sort_crossings()
      integer :: m, n, s
      real(dp) :: zz
      do m = 2, n_crossings
        zz = crossing_z(m)
        s = crossing_sign(m)
        n = m - 1
        do while (n >= 1)
          if (crossing_z(n) <= zz) exit
          crossing_z(n + 1) = crossing_z(n)
          crossing_sign(n + 1) = crossing_sign(n)
          n = n - 1
        end do
        crossing_z(n + 1) = zz
        crossing_sign(n + 1) = s
      end do
    end subroutine sort_crossings
  end subroutine fill_mesh_on_lattice

  !> Twice the signed area of (p, q, r) in the xy plane: > 0 when r is left of p -> q.
  pure real(dp) function edge_function(p, q, r)
    real(dp), intent(in) :: p(3), q(3), r(2)
    edge_function = (q(1) - p(1)) * (r(2) - p(2)) - (q(2) - p(2)) * (r(1) - p(1))
  end function edge_function

end module beadmob_triangle_mesh
